"""What became of each point of a sweep, and counts that add up.

Every point of a sweep ends in exactly one of three ways:

- **solved**: it has every metric the sweep asked for (its gait and, with simulate = true, its
  simulation's verdict; a walk that fell is a verdict, so a solved point may have fallen);
- **failed**: it has not, with one line saying why: the planner found no gait (the constraint
  it ran into), refused the settings, the gait solved but the walk, torques or simulation
  could not be made, or the evaluation itself failed in the worker (a bug, a lost worker);
- **cancelled**: the sweep stopped before its result came back.

So done = solved + failed + cancelled, and done + pending = the sweep's points, at every moment.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

from app.core.sweeps.evaluate import PointResult

STAGES = ("gait", "refused", "simulation", "worker")
"""Where a failed point failed: no gait, settings refused, the simulation, the worker."""
SIMULATION_PREFIX = "not simulated: "


@dataclasses.dataclass(frozen=True)
class PointOutcome:
    """One returned point: solved, or failed with its stage and one-line reason."""

    index: int
    failed: bool
    stage: str = ""
    """Where it failed (one of STAGES), "" when solved."""
    reason: str = ""
    """Why, in one line ("" when solved)."""

    def line(self) -> str:
        """ "gait: <why>" for a failed point, "solved" otherwise."""
        return f"{self.stage}: {self.reason}" if self.failed else "solved"


def _one_line(text: str) -> str:
    return " ".join(text.split()) or "no reason given"


def outcome_of(result: PointResult, simulate: bool) -> PointOutcome:
    """Solved or failed (with where and why) for a point of a sweep with or without simulation."""
    if result.status == "failed":  # evaluate's failed_point: the task raised every retry
        return PointOutcome(result.index, True, "worker", _one_line(result.reason))
    if not result.solved:
        stage = "refused" if result.status == "refused" else "gait"
        return PointOutcome(result.index, True, stage, _one_line(result.reason or result.status))
    if simulate and not math.isfinite(result.fell):
        why = result.sim_status.removeprefix(SIMULATION_PREFIX)
        return PointOutcome(result.index, True, "simulation", _one_line(why))
    return PointOutcome(result.index, False)


def completed(result: PointResult, simulate: bool) -> bool:
    """Whether the point is solved (has every metric the sweep asked for)."""
    return not outcome_of(result, simulate).failed


@dataclasses.dataclass(frozen=True)
class SweepTally:
    """A sweep's points counted: solved + failed + cancelled + pending = total."""

    total: int
    solved: int
    failed: int
    cancelled: int
    pending: int
    fell: int = 0
    """Solved points whose walk fell in the simulation (counted in `solved`)."""
    simulate: bool = False

    @property
    def done(self) -> int:
        return self.solved + self.failed + self.cancelled

    def line(self) -> str:
        """ "3 / 4 done: 2 solved, 1 failed, 0 cancelled" (and the fallen, with simulation)."""
        solved = f"{self.solved} solved"
        if self.simulate:
            solved += f" ({self.fell} fell in simulation)"
        return (
            f"{self.done} / {self.total} done: {solved}, {self.failed} failed, "
            f"{self.cancelled} cancelled"
        )


def tally(
    results: Sequence[PointResult], total: int, simulate: bool, finished: bool = False
) -> SweepTally:
    """The counts of a sweep of `total` points with `results` back; `finished` (the sweep
    ended, by cancel or otherwise): every point not back is cancelled, none pending."""
    indices = {r.index for r in results}
    if len(indices) != len(results) or len(results) > total:
        raise ValueError(f"{len(results)} results ({len(indices)} points) for {total} points")
    outcomes = [outcome_of(r, simulate) for r in results]
    failed = sum(o.failed for o in outcomes)
    solved = len(results) - failed
    fell = sum(1 for r, o in zip(results, outcomes, strict=True) if not o.failed and r.fell == 1.0)
    missing = total - len(results)
    return SweepTally(
        total,
        solved,
        failed,
        cancelled=missing if finished else 0,
        pending=0 if finished else missing,
        fell=fell,
        simulate=simulate,
    )


def failures(results: Sequence[PointResult], simulate: bool) -> list[PointOutcome]:
    """The failed points, in index order."""
    out = [outcome_of(r, simulate) for r in sorted(results, key=lambda r: r.index)]
    return [o for o in out if o.failed]
