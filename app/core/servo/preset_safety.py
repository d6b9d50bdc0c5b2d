"""Coefficients that would drive a robot past its joint limits are scaled, with the reason.

The paper's presets (Tables 2 and 3) were identified on Roban; on another robot, or with
other torques, k·τ can ask a servo for more than it can turn (servo_biped with Table 2: the
studio's own model then predicts a 179° torso roll). Before such coefficients are used:

- `limit_scale` finds the largest s ∈ [0, 1] such that the commands with every k scaled by s,

      q_cmd(s) = q + s·k·τ + φ·sign(·)            (eq 7 / eq 23)

  stay within [lower, upper] at every sample (bisection to 1e-4, φ kept: the clearance
  is the servo's, not the plan's); s = 0 when even the plain plan with φ does not fit;
- `scaled_to_limits` returns the coefficients with k → s·k and a note saying why;
- `implausible_prediction` lists what makes a prediction absurd: torso roll or pitch more
  than MAX_TORSO_ERROR_DEG away from the plan's.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from app.core.servo.compensation import CompensationParams, compensated_command
from app.core.servo.model import Prediction

MAX_TORSO_ERROR_DEG = 30.0
"""A predicted torso attitude this far from the plan's is a fall, not a compensation."""
SCALE_TOLERANCE = 1e-4


def _fits(q_cmd: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> bool:
    return bool(np.all(np.isfinite(q_cmd)) and np.all(q_cmd >= lower) and np.all(q_cmd <= upper))


def _with_scale(params: CompensationParams, s: float) -> CompensationParams:
    return dataclasses.replace(params, k_deg_per_Nm=params.k_deg_per_Nm * s)


def limit_scale(
    params: CompensationParams,
    q_plan_rad: np.ndarray,
    tau_Nm: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
) -> float:
    """Largest s ∈ [0, 1] (to SCALE_TOLERANCE) whose commands stay within the limits [rad]."""
    if _fits(compensated_command(q_plan_rad, tau_Nm, params), lower, upper):
        return 1.0
    if not _fits(compensated_command(q_plan_rad, tau_Nm, _with_scale(params, 0.0)), lower, upper):
        return 0.0
    low, high = 0.0, 1.0
    while high - low > SCALE_TOLERANCE:
        middle = 0.5 * (low + high)
        command = compensated_command(q_plan_rad, tau_Nm, _with_scale(params, middle))
        low, high = (middle, high) if _fits(command, lower, upper) else (low, middle)
    return low


def scaled_to_limits(
    params: CompensationParams,
    q_plan_rad: np.ndarray,
    tau_Nm: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
) -> tuple[CompensationParams, float]:
    """(coefficients, s): k scaled by `limit_scale`'s s, with a note saying why (unchanged
    when s = 1). s = 0 means the plan itself (with φ) leaves the limits: nothing fits."""
    s = limit_scale(params, q_plan_rad, tau_Nm, lower, upper)
    if s == 1.0:
        return params, s
    note = (
        f"k scaled by {s:.3g}: the coefficients as given would command joints past their "
        "limits on this motion"
        if s > 0.0
        else "even with k = 0 the commands leave the joint limits (the plan or φ does)"
    )
    scaled = _with_scale(params, s)
    return dataclasses.replace(scaled, notes=(*params.notes, note)), s


def implausible_prediction(prediction: Prediction) -> list[str]:
    """Why a prediction is absurd (torso attitude far from the plan's), or [] if it is not."""
    reasons = []
    for label, errors in prediction.attitude_errors_deg().items():
        if not math.isfinite(errors) or errors > MAX_TORSO_ERROR_DEG:
            reasons.append(
                f"predicted torso {label.replace('_', ' ')} is {errors:.0f}° off the plan "
                f"(over {MAX_TORSO_ERROR_DEG:g}°): the robot would fall"
            )
    return reasons
