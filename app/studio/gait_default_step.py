"""The Gait panel's side of the shortened default step (app/core/walking/start_fit.py).

When a solve of the robot-derived default step length gives a walk that cannot start (no start
ramp the legs can follow: Roban S14's 16.9 cm steps), the panel searches the longest step that
can, one worker solve per step tried (StepSearch: 5 at most, warm-started from the last), then
solves the step found once more so that the panel's settings, the last solve and the gait
shown agree, and says so in one line. A step the user moved off the default is kept as set;
dircon_biped keeps the paper's.
"""

from __future__ import annotations

from app.core.collocation.planar_model import PlanarModel
from app.core.walking.start_fit import SEARCH_SOLVES, StepSearch, start_fits
from app.studio.gait_text import Solve


class DefaultStep:
    """The search's state across the worker's solves (one at a time)."""

    def __init__(self) -> None:
        self.default_m: float | None = None
        """The robot-derived default step length [m]; None: never shortened (paper robot)."""
        self.search: StepSearch | None = None
        self.trying = 0.0
        self.final = False
        self.note: str | None = None
        """The last search's one line (None once shown: `pop_note`)."""

    def robot(self, default_m: float | None) -> None:
        """A new robot: its default step length, and no search."""
        self.default_m, self.search, self.final, self.note = default_m, None, False, None

    def next_step(self, planar: PlanarModel | None, ended: Solve) -> float | None:
        """After the solve `ended`: the step length [m] to solve next, or None (no search, or
        it is over: `note` says how it ended)."""
        result = ended.result
        if self.search is None:
            if (
                planar is None
                or self.default_m is None
                or ended.settings.baseline
                or result is None
                or not result.converged
                or ended.settings.step_length_m != self.default_m
                or start_fits(planar, result)
            ):
                return None
            self.search = StepSearch(self.default_m, self.default_m / result.duration_s)
            self.note = None
        elif result is None or ended.error == "cancelled":  # cancelled or the worker failed
            self.search, self.final = None, False
            return None
        elif self.final:
            self.note = self.search.note()
            self.search, self.final = None, False
            return None
        else:
            starts = planar is not None and result.converged and start_fits(planar, result)
            self.search.record(self.trying, starts)
        step = self.search.next_step()
        if step is None:
            if not self.search.found:
                self.note = self.search.note()
                self.search = None
                return None
            self.final, step = True, self.search.lo
        self.trying = step
        return step

    def stop(self) -> None:
        """No search any more (its next solve could not be launched)."""
        self.search, self.final = None, False

    def pop_note(self) -> str | None:
        """The line of the search that just ended, once."""
        note, self.note = self.note, None
        return note

    def words(self) -> str:
        """What the panel shows while the search runs."""
        search = self.search
        if search is None:
            return ""
        was = f"{50 * search.default_m:.1f} cm"
        if self.final:
            return (
                f"Default steps of {was} cannot start a walk: solving the {50 * self.trying:.1f} "
                "cm steps found once more…"
            )
        return (
            f"Default steps of {was} cannot start a walk (no start ramp fits): trying "
            f"{50 * self.trying:.1f} cm steps ({search.tried + 1}/{SEARCH_SOLVES} at most)…"
        )
