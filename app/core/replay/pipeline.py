"""The headless replay: a built-in motion, its torque feed-forward, the quick prediction with
and without compensation, and the scene with the four predicted ghosts and a title card."""

from __future__ import annotations

import numpy as np

from app.core.dynamics.wbc import torque_feedforward
from app.core.motions.library import resolve_params, run_motion
from app.core.replay.scene import (
    DEFAULT_FRAME_RATE_HZ,
    PREDICTED_GHOSTS,
    ReplayScene,
    replay_scene,
    title_card,
)
from app.core.robot.model import RobotModel
from app.core.servo.compensation import CompensationParams
from app.core.servo.model import Prediction, ServoModel, predict


def prediction_verdicts(prediction: Prediction) -> tuple[str, ...]:
    """The quick estimate's verdict lines: largest torso error without and with compensation."""
    e = prediction.attitude_errors_deg()
    return (
        f"quick estimate, no compensation: roll {e['roll_uncompensated']:.2f}°, "
        f"pitch {e['pitch_uncompensated']:.2f}°",
        f"quick estimate, compensated: roll {e['roll_compensated']:.2f}°, "
        f"pitch {e['pitch_compensated']:.2f}°",
    )


def headless_scene(
    robot: RobotModel,
    motion: str,
    params: dict[str, str],
    coefficients: CompensationParams,
    servo: ServoModel,
    preset_label: str,
    dt: float = 0.01,
    frame_rate_hz: float = DEFAULT_FRAME_RATE_HZ,
    ghosts: tuple[str, ...] = PREDICTED_GHOSTS,
) -> ReplayScene:
    """Everything the studio's pipeline shows for a built-in motion, without the studio."""
    resolved = resolve_params(motion, params)
    trajectory = run_motion(robot, motion, dt=dt, **params).trajectory
    feedforward = torque_feedforward(robot, trajectory)
    prediction = predict(robot, trajectory, np.nan_to_num(feedforward.tau_Nm), coefficients, servo)
    shown = {name: str(value) for name, value in resolved.items() if value is not None}
    title = title_card(
        robot.name,
        motion,
        trajectory.duration,
        {**shown, "compensation": preset_label},
        prediction_verdicts(prediction),
    )
    return replay_scene(
        robot, trajectory, title, prediction, ghosts=ghosts, frame_rate_hz=frame_rate_hz
    )
