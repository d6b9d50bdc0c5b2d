"""Servo commands of a motion: the pipeline's step from (motion, torques, coefficients) to what
the servos are sent, with every check it needs. Shared by the CLI, the studio and the bench."""

from __future__ import annotations

import dataclasses

import numpy as np

from app.core.motions.trajectory import Trajectory
from app.core.robot.model import RobotModel
from app.core.servo.compensation import (
    CompensationError,
    CompensationParams,
    command_limit_violations,
    compensated_command,
)
from app.core.servo.files import TorqueTable
from app.core.servo.model import joint_angles

GOOD_STATUSES = ("", "ok", "solved")
"""Torque sample statuses that need no warning."""


@dataclasses.dataclass(frozen=True, eq=False)
class ServoCommands:
    t: np.ndarray
    """Sample times [s], shape (T,)."""
    q_plan_rad: np.ndarray
    """Planned joint angles [rad], shape (T, n)."""
    q_cmd_rad: np.ndarray
    """Commands q + k·τ (+ φ·sign) [rad], shape (T, n) (eq 7, eq 23)."""
    warnings: tuple[str, ...]
    """Joints whose commands leave their limits; torque samples the QP did not solve."""
    lower_rad: np.ndarray
    upper_rad: np.ndarray
    """The joints' position limits [rad], shape (n,): a command file is refused outside them."""


def torques_of_motion(trajectory: Trajectory, torques: TorqueTable, source: str) -> np.ndarray:
    """The torques (T, n) [N·m] of a torque table that was computed for this motion: same
    number of samples at the same times (from any start). CompensationError otherwise."""
    if len(torques.t) != trajectory.n_samples:
        raise CompensationError(
            f"{source} has {len(torques.t)} samples but the motion has {trajectory.n_samples}"
        )
    t_tau = torques.t - torques.t[0]
    worst = int(np.argmax(np.abs(t_tau - trajectory.t)))
    if abs(t_tau[worst] - trajectory.t[worst]) > 1e-3 * trajectory.dt + 1e-9:
        raise CompensationError(
            f"{source}: sample {worst} is at t = {torques.t[worst]:g} s, the motion's at "
            f"{trajectory.t[worst]:g} s; the torques must come from this motion"
        )
    return torques.tau_Nm


def servo_commands(
    robot: RobotModel,
    trajectory: Trajectory,
    tau_Nm: np.ndarray,
    params: CompensationParams,
    statuses: tuple[str, ...] = (),
) -> ServoCommands:
    """Commands for every sample (eq 7 / eq 23 with `params`), and what to warn about."""
    params = params.for_joints(robot.joint_names)
    q_plan = joint_angles(robot, trajectory.q)
    q_cmd = compensated_command(q_plan, np.asarray(tau_Nm, dtype=float), params)
    lower = np.array([joint.lower for joint in robot.joints])
    upper = np.array([joint.upper for joint in robot.joints])
    warnings = command_limit_violations(params, q_cmd, lower, upper)
    for status in sorted({s for s in statuses if s.lower() not in GOOD_STATUSES}):
        count = sum(s == status for s in statuses)
        warnings.append(f"{count} torque sample(s) have status {status!r}")
    return ServoCommands(trajectory.t, q_plan, q_cmd, tuple(warnings), lower, upper)
