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
STEP_ROUNDING_M = 0.001
"""The step lengths tried are rounded to this [m] (two steps' advance)."""


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


def fit_default_step(
    planar: PlanarModel,
    settings: GaitSettings,
    result: GaitResult,
    solve: Callable[[GaitSettings], GaitResult],
) -> StepFit:
    """`settings` (the robot's defaults) and `result` (their solve) kept when the walk can
    start, else the longest step length (a bisection, SEARCH_SOLVES `solve` calls at most) at
    which it can, its result and a note. Use it only for a step length the user did not set."""
    if not result.converged or start_fits(planar, result):
        return StepFit(settings, result, None)
    default = settings.step_length_m
    speed = default / result.duration_s  # the gait's mean speed
    lo, hi = 0.0, default
    best: tuple[GaitSettings, GaitResult] | None = None
    for _ in range(SEARCH_SOLVES):
        mid = round(0.5 * (lo + hi) / STEP_ROUNDING_M) * STEP_ROUNDING_M
        if not lo < mid < hi:
            break
        trial = dataclasses.replace(settings, step_length_m=mid)
        trial_result = solve(trial)
        if trial_result.converged and start_fits(planar, trial_result):
            lo, best = mid, (trial, trial_result)
        else:
            hi = mid
    was = f"{50 * default:.1f} cm ({speed:.2f} m/s)"
    if best is None:
        return StepFit(
            settings,
            result,
            f"default steps of {was} kept: no shorter step the search tried "
            f"({100 * hi:.1f} cm advance and up) lets the legs reach the gait's speed with "
            "both feet down",
        )
    fitted, fitted_result = best
    note = (
        f"default steps shortened from {50 * default:.1f} to {50 * lo:.1f} cm "
        f"(step_length_m {default:g} → {lo:g}) so the walk can start: at {was} the legs "
        "cannot reach the gait's speed with both feet down; set step_length_m to choose"
    )
    return StepFit(fitted, fitted_result, note)
