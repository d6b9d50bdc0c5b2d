"""Whether a walk can start, and a robot's default step shortened until it can.

A walk's start brings the body from rest to the gait's speed with both feet down, by the
longest ramp the legs can follow within the soles (walk.py). When none fits, the walk jumps
to the gait's speed at the first lift-off, and on servos the body that never gets the speed
falls (Roban S14's robot-derived 16.9 cm steps, docs/simulation.md). The fit is the walk's own
test (`_PlanarWalk`, the same one `build_walk` runs); it depends on the solved touch-down
posture as well as on the speed, so the search solves the gait at each step length it tries:
a bisection between no advance and the default, SEARCH_SOLVES solves at most.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

from app.core.collocation.planar_model import PlanarModel
from app.core.collocation.result import GaitResult
from app.core.collocation.settings import GaitSettings
from app.core.walking.walk import _PlanarWalk

SEARCH_SOLVES = 5
"""Gait solves the search takes at most: the step found is within 1/32 of the default's."""
STEP_DECIMALS = 3
"""The step lengths tried are rounded to 1 mm (two steps' advance, m)."""


@dataclasses.dataclass(frozen=True)
class StepFit:
    settings: GaitSettings
    result: GaitResult
    note: str | None
    """One line when the default step was shortened (or could not be), else None."""


def start_fits(planar: PlanarModel, result: GaitResult) -> bool:
    """Whether a walk of `result` can start with a ramp to the gait's speed (both feet down,
    within the soles), as `build_walk` decides it with its default start of one cycle."""
    H = result.duration_s
    return _PlanarWalk(planar, result, 1, H, H).match_speed["start"]


class StepSearch:
    """The bisection over the step length (two steps' advance) between no advance (assumed to
    start: nothing to reach) and `default_m` (does not): `next_step` to try, `record` whether
    its walk can start; SEARCH_SOLVES steps at most. The CLI and the studio share it."""

    def __init__(self, default_m: float, mean_speed_mps: float) -> None:
        self.default_m, self.mean_speed_mps = default_m, mean_speed_mps
        self.lo, self.hi, self.tried = 0.0, default_m, 0

    def next_step(self) -> float | None:
        """The next step length to try [m], None when the search is over."""
        if self.tried >= SEARCH_SOLVES:
            return None
        mid = round(0.5 * (self.lo + self.hi), STEP_DECIMALS)
        return mid if self.lo < mid < self.hi else None

    def record(self, step_m: float, starts: bool) -> None:
        """Whether a walk of the gait solved at `step_m` can start."""
        self.tried += 1
        if starts:
            self.lo = step_m
        else:
            self.hi = step_m

    @property
    def found(self) -> bool:
        return self.lo > 0.0

    def note(self) -> str:
        """The one line the user reads: the step shortened, or kept when none shorter starts."""
        was = f"{50 * self.default_m:.1f} cm ({self.mean_speed_mps:.2f} m/s)"
        if not self.found:
            return (
                f"default steps of {was} kept: no shorter step the search tried "
                f"({100 * self.hi:.1f} cm advance and up) lets the legs reach the gait's speed "
                "with both feet down"
            )
        return (
            f"default steps shortened from {50 * self.default_m:.1f} to {50 * self.lo:.1f} cm "
            f"(step_length_m {self.default_m:g} → {self.lo:g}) so the walk can start: at {was} "
            "the legs cannot reach the gait's speed with both feet down; set step_length_m to "
            "choose"
        )


def fit_default_step(
    planar: PlanarModel,
    settings: GaitSettings,
    result: GaitResult,
    solve: Callable[[GaitSettings], GaitResult],
) -> StepFit:
    """`settings` (the robot's defaults) and `result` (their solve) kept when the walk can
    start, else the longest step length (StepSearch, SEARCH_SOLVES `solve` calls at most) at
    which it can, its result and a note. Use it only for a step length the user did not set."""
    if not result.converged or start_fits(planar, result):
        return StepFit(settings, result, None)
    search = StepSearch(settings.step_length_m, settings.step_length_m / result.duration_s)
    tried: dict[float, tuple[GaitSettings, GaitResult]] = {}
    while (step := search.next_step()) is not None:
        trial = dataclasses.replace(settings, step_length_m=step)
        tried[step] = trial, solve(trial)
        search.record(step, tried[step][1].converged and start_fits(planar, tried[step][1]))
    if not search.found:
        return StepFit(settings, result, search.note())
    return StepFit(*tried[search.lo], search.note())
