"""The gait settings a user tunes, with the ranges a hand can drag: the gait panel's sliders are
built from this list and return a GaitSettings, so the settings have one source of truth.

Each range lies inside what `GaitSettings.validate` accepts; the studio re-checks values as they
arrive (a crafted client can send any number).
"""

from __future__ import annotations

import dataclasses

from app.core.collocation.settings import GaitSettings, GaitSettingsError


@dataclasses.dataclass(frozen=True)
class Control:
    """One slider over one GaitSettings field."""

    field: str
    label: str
    minimum: float
    maximum: float
    step: float
    hint: str = ""


SLACK_HINT = (
    "Foothold slack: x1 = (0.5 + slack0)(x0 + x2), a ≤ slack0 ≤ b (paper: ±0.05). With identical "
    "legs and exchanged joint states the two steps mirror each other, so slack0 is 0: the bounds "
    "must include 0"
)
"""Help for the slack bounds (a two-handled slider over slack_a and slack_b)."""
SLACK_RANGE = (-0.5, 0.5, 0.01)

CONTROLS: tuple[Control, ...] = (
    Control("K0", "K0 energy", 0.0, 20.0, 0.1, "Weight of the energy term K0·h·Σ‖u‖² (paper 6.5)"),
    Control("K1", "K1 slack", 0.0, 20.0, 0.1, "Weight of the foothold slack term K1·slack0²"),
    Control("K2", "K2 smoothness", 0.0, 20.0, 0.1, "Weight of the smoothness term (paper 1.5)"),
    Control("H_s", "H, two steps [s]", 0.3, 2.0, 0.01, "Duration of the complete gait (LSP + RSP)"),
    Control(
        "step_length_m", "advance, two steps [m]", 0.0, 0.6, 0.005, "How far the two steps advance"
    ),
    Control(
        "swing_height_m", "swing height ≤ [m]", 0.01, 0.2, 0.001, "Highest the swing sole may rise"
    ),
    Control(
        "swing_clearance_m",
        "swing clearance ≥ [m]",
        0.0,
        0.1,
        0.001,
        "Lowest the swing sole may be at mid-swing (not in the paper: without it the optimum "
        "shuffles the foot along the floor)",
    ),
    Control(
        "knots",
        "knots",
        5,
        160,
        1,
        "Knots of the three modes (+2 virtual); paper 38. Above 38 a first solve solves 38 "
        "knots first and starts from it (mesh refinement)",
    ),
    Control("mu", "μ", 0.1, 1.5, 0.05, "Friction coefficient of the ground"),
    Control(
        "pelvis_height_ratio",
        "pelvis height ≤ × standing",
        0.8,
        1.0,
        0.005,
        "Highest the pelvis may be, as a fraction of its standing height: below 1 the knees "
        "must stay bent, as the paper's robot walks",
    ),
    Control(
        "knee_flexion_min_rad",
        "knee bend ≥ [rad]",
        0.0,
        1.0,
        0.01,
        "Smallest knee flexion at every knot (0: only the joint limits)",
    ),
    Control(
        "touchdown_speed_max_mps",
        "touch-down speed ≤ [m/s]",
        0.05,
        1.0,
        0.01,
        "Fastest the swing sole may hit the floor (a soft landing)",
    ),
    Control(
        "K_impact",
        "K impact loss",
        0.0,
        50.0,
        0.5,
        "Weight of the kinetic energy lost in the touch-down impacts (½ Δvᵀ M Δv)",
    ),
)
"""The sliders, in panel order, after the slack bounds."""


def settings_with(base: GaitSettings, values: dict[str, float | bool]) -> GaitSettings:
    """`base` with the controls' values (knots made whole), validated: a value outside its
    control's range is refused as GaitSettingsError, as is anything GaitSettings refuses."""
    fields = {f.name for f in dataclasses.fields(GaitSettings)}
    ranges = {c.field: (c.minimum, c.maximum) for c in CONTROLS}
    ranges["slack_a"] = ranges["slack_b"] = SLACK_RANGE[:2]
    changes: dict[str, object] = {}
    for name, value in values.items():
        if name not in fields:
            raise GaitSettingsError(f"{name} is not a gait setting")
        if name in ranges:
            low, high = ranges[name]
            if not low <= float(value) <= high:
                raise GaitSettingsError(
                    f"{name} = {value:g} is outside its slider's range [{low:g}, {high:g}]"
                )
        if name == "baseline":
            changes[name] = bool(value)
        else:
            changes[name] = round(value) if name == "knots" else float(value)
    return dataclasses.replace(base, **changes).validate()  # type: ignore[arg-type]
