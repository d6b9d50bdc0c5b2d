"""The torque eq 7 compensates for a simulated run: the plan's load torque τ, or the servos'
drive torque τ + D·q̇ + J·q̈ (`app.core.servo.compensation.drive_torque_Nm`) with the D and J
of the servos the run simulates. One function for the CLI (`simulate --drive-torque`) and the
studio (the Compensation folder's *compensate* choice), so both compensate the same torque.

A position servo's spring must deliver the load torque and also drive its own rotor and
back-EMF: on τ alone a moving joint lags its plan by c·D·q̇ (servo_biped's walk then covers
64 % of its planned distance; on the drive torque, all of it: docs/simulation.md).
"""

from __future__ import annotations

from typing import Literal, TypeAlias

import numpy as np

from app.core.motions.trajectory import Trajectory
from app.core.robot.model import RobotModel
from app.core.servo.compensation import drive_torque_Nm
from app.core.servo.model import ServoModel
from app.core.simulation.mjcf import SimOptions
from app.core.simulation.part_law import PartLaw
from app.core.simulation.servo_law import ServoLaw, robot_servo_law

CompensatedTorque: TypeAlias = Literal["drive", "load"]
"""Which torque eq 7 multiplies: "drive" τ + D·q̇ + J·q̈, "load" τ (the paper's eq 7)."""
COMPENSATED_TORQUES: tuple[CompensatedTorque, ...] = ("drive", "load")
DEFAULT_COMPENSATED_TORQUE: CompensatedTorque = "drive"
"""The studio's default: what makes a walk on servos walk."""


def rotor_inertia_kgm2(robot: RobotModel, law: ServoLaw, options: SimOptions) -> np.ndarray:
    """Each actuated joint's reflected rotor inertia J [kg·m²] in a run, shape (n,): a servo
    part's own, the model's armature (`SimOptions.armature_kgm2`) elsewhere."""
    rotor = np.full(robot.n_actuated, options.armature_kgm2)
    if isinstance(law, PartLaw):
        mine = slice(None) if law.has_part is None else law.has_part
        rotor[mine] = law.armature_kgm2[mine]
    return rotor


def plan_drive_torque_Nm(
    robot: RobotModel,
    trajectory: Trajectory,
    tau_Nm: np.ndarray,
    servo: ServoModel,
    law: ServoLaw | None = None,
    options: SimOptions | None = None,
) -> np.ndarray:
    """τ + D·q̇ + J·q̈ [N·m], shape (T, n), along the plan's joint speeds and accelerations,
    with the D and J a run of `robot` simulates: `law` (servo parts) or the virtual servos'
    (`robot_servo_law`: the URDF's τ_max/ω_max, the sized torque where it gives none)."""
    law = law if law is not None else robot_servo_law(robot, servo)
    options = options or SimOptions()
    columns = [joint.idx_v for joint in robot.joints]
    return drive_torque_Nm(
        tau_Nm,
        trajectory.v[:, columns],
        trajectory.a[:, columns],
        law.damping_Nms_per_rad,
        rotor_inertia_kgm2(robot, law, options),
    )


def compensated_torque_Nm(
    robot: RobotModel,
    trajectory: Trajectory,
    tau_Nm: np.ndarray,
    torque: CompensatedTorque,
    servo: ServoModel,
    law: ServoLaw | None = None,
    options: SimOptions | None = None,
) -> np.ndarray:
    """The torque eq 7 takes [N·m], shape (T, n): τ itself ("load") or its drive torque
    ("drive", `plan_drive_torque_Nm`)."""
    tau = np.asarray(tau_Nm, dtype=float)
    if torque == "load":
        return tau
    return plan_drive_torque_Nm(robot, trajectory, tau, servo, law, options)
