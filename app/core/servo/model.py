"""What a position servo actually does under load, and what the torso then does.

The servo model (per joint, static, memoryless):

    q_actual = q_cmd − c·τ − (b/2)·sign(τ)

τ [N·m] is the torque the servo delivers to hold its load (the torque feed-forward), c its
compliance [°/(N·m)] and b the width of its dead band (backlash) [°]. The position loop acts like
a torsion spring of stiffness 1/c, so delivering τ needs the output to lag the command by c·τ
(Hooke, the paper's eq 6 → eq 7). The gear train then has ±b/2 of play; the load, which pushes
against τ, keeps the teeth against the far face of the gap, so the output sits b/2 further back,
opposite to τ. At τ = 0 exactly the output is taken at the centre of the gap. (A real dead band
has hysteresis: while |τ| is about zero the output stays wherever it last was; this model has no
memory.)

Its exact inverse is eq 23 with the torque sign rule and φ = b/2:

    q_cmd = q + c·τ + (b/2)·sign(τ)       (`CompensationParams(..., clearance_sign="torque")`)

The paper's own sign rule, sign(q + k·τ), coincides with it only where the compensated angle
and the torque have the same sign; elsewhere it is off by b (= 2φ).

The torso attitude: with the joints at their predicted actual angles, the robot is put down
rigidly so that its stance foot has exactly the placement the plan gives it (flat on the
ground for a plan that keeps it flat), and the root link's roll and pitch are read in the
world, as an IMU near the hip (the paper's JY901) would read them.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import ClassVar

import numpy as np
import pinocchio as pin

from app.core.errors import StudioError
from app.core.motions.trajectory import Trajectory
from app.core.posing.stance import anchor_on_foot, stance_link
from app.core.robot.model import RobotModel
from app.core.servo.compensation import (
    MAX_ABS_K_DEG_PER_NM,
    CompensationParams,
    compensated_command,
)
from app.core.servo.per_joint import PerJointRecord, check_range, per_joint


class ServoModelError(StudioError):
    """Servo parameters or inputs that are invalid or do not fit the robot."""


@dataclasses.dataclass(frozen=True, eq=False)
class ServoModel(PerJointRecord):
    """The true mechanics of each servo, one entry per joint of `joint_names` (`for_joints`:
    joints not named are rigid)."""

    COLUMNS: ClassVar[tuple[str, ...]] = ("compliance_deg_per_Nm", "backlash_deg")
    ERROR: ClassVar[type[StudioError]] = ServoModelError

    compliance_deg_per_Nm: np.ndarray
    """The servo's true k: output lag per delivered torque [°/(N·m)], shape (n,)."""
    backlash_deg: np.ndarray
    """Full width b of the dead band [°], shape (n,), ≥ 0; the output sits b/2 off centre."""

    def __post_init__(self) -> None:
        names = tuple(self.joint_names)
        n = len(names)
        compliance = per_joint(
            "compliance_deg_per_Nm", self.compliance_deg_per_Nm, n, ServoModelError
        )
        backlash = per_joint("backlash_deg", self.backlash_deg, n, ServoModelError)
        limit = (-MAX_ABS_K_DEG_PER_NM, MAX_ABS_K_DEG_PER_NM)
        check_range("compliance", compliance, names, limit, " °/(N·m)", ServoModelError)
        check_range("backlash", backlash, names, (0.0, 90.0), "°", ServoModelError)
        object.__setattr__(self, "joint_names", names)
        object.__setattr__(self, "compliance_deg_per_Nm", compliance)
        object.__setattr__(self, "backlash_deg", backlash)

    @classmethod
    def rigid(cls, joint_names: Sequence[str]) -> ServoModel:
        """Ideal servos: no compliance, no backlash."""
        n = len(joint_names)
        return cls(tuple(joint_names), np.zeros(n), np.zeros(n))

    @classmethod
    def matching(cls, params: CompensationParams) -> ServoModel:
        """The servos that `params` compensates exactly when its clearance sign is "torque":
        compliance k and backlash 2φ on enabled joints, rigid elsewhere."""
        on = params.enabled
        return cls(
            params.joint_names,
            np.where(on, params.k_deg_per_Nm, 0.0),
            np.where(on, 2.0 * params.phi_deg, 0.0),
        )


def servo_response(q_cmd_rad: np.ndarray, tau_Nm: np.ndarray, model: ServoModel) -> np.ndarray:
    """Settled output angles [rad], shape (T, n): q_cmd − c·τ − (b/2)·sign(τ) (module docstring)."""
    q_cmd = np.asarray(q_cmd_rad, dtype=float)
    tau = np.asarray(tau_Nm, dtype=float)
    n = len(model.joint_names)
    if q_cmd.ndim != 2 or q_cmd.shape[1] != n or tau.shape != q_cmd.shape:
        raise ServoModelError(
            f"commands {q_cmd.shape} and torques {tau.shape} must both have shape (T, {n})"
        )
    if not (np.all(np.isfinite(q_cmd)) and np.all(np.isfinite(tau))):
        raise ServoModelError("commands or torques contain NaN or infinite values")
    return settled(q_cmd, tau, model)


def settled(q_cmd: np.ndarray, tau: np.ndarray, model: ServoModel) -> np.ndarray:
    """`servo_response`'s equation alone, on float arrays it has accepted."""
    out = q_cmd - np.deg2rad(model.compliance_deg_per_Nm) * tau
    out -= np.deg2rad(0.5 * model.backlash_deg) * np.sign(tau)
    return out


# --- whole-robot consequences --------------------------------------------------------------


def joint_angles(robot: RobotModel, q: np.ndarray) -> np.ndarray:
    """Actuated joint angles [rad or m], shape (T, n), of configurations q (T, nq)."""
    out = np.empty((len(q), robot.n_actuated))
    for i, joint in enumerate(robot.joints):
        if joint.kind == "continuous":
            out[:, i] = np.arctan2(q[:, joint.idx_q + 1], q[:, joint.idx_q])
        else:
            out[:, i] = q[:, joint.idx_q]
    return out


def with_joint_angles(
    robot: RobotModel, q: np.ndarray, angles: np.ndarray, out: np.ndarray | None = None
) -> np.ndarray:
    """A copy of configurations q (T, nq) with the actuated joints set to `angles` (T, n),
    into `out` when given."""
    if out is None:
        out = np.array(q, dtype=float)
    else:
        out[:] = q
    for i, joint in enumerate(robot.joints):
        if joint.kind == "continuous":
            out[:, joint.idx_q] = np.cos(angles[:, i])
            out[:, joint.idx_q + 1] = np.sin(angles[:, i])
        else:
            out[:, joint.idx_q] = angles[:, i]
    return out


def stance_is_right(contacts: np.ndarray) -> np.ndarray:
    """Per sample, whether the robot stands on its right foot, shape (T,) bool: only when the
    right foot alone is in contact. Double support and flight use the left foot, as
    `app.core.posing.stance.stance_link` does (the plan holds both feet, so either would do while
    the joints are exact; with deflected joints the left foot is kept and the right one may
    float or sink by the difference)."""
    contacts = np.asarray(contacts, dtype=bool)
    return contacts[:, 1] & ~contacts[:, 0]


def planned_stance_placements(robot: RobotModel, trajectory: Trajectory) -> list[pin.SE3]:
    """T_world_foot of each sample's stance foot in the plan."""
    model, data = robot.model, robot.model.createData()
    frames = [robot.link_frame_ids[foot.link] for foot in robot.feet]
    right = stance_is_right(trajectory.contacts)
    out = []
    for k in range(trajectory.n_samples):
        pin.forwardKinematics(model, data, trajectory.q[k])
        out.append(pin.SE3(pin.updateFramePlacement(model, data, frames[int(right[k])])))
    return out


def grounded_configurations(
    robot: RobotModel,
    trajectory: Trajectory,
    q_joints: np.ndarray,
    planned_placements: list[pin.SE3] | None = None,
) -> np.ndarray:
    """Configurations (T, nq) with the joints at `q_joints` (T, n) and the floating base moved
    rigidly so that each sample's stance foot (`stance_is_right`) sits exactly where the plan
    puts it. Passive loop joints keep their planned values (loops are not re-closed).
    `planned_placements` (the plan's stance-foot placements) saves recomputing them."""
    if not robot.floating_base:
        raise ServoModelError(
            f"{robot.name} has a fixed base: the torso cannot tilt, there is nothing to predict"
        )
    q_joints = np.asarray(q_joints, dtype=float)
    if q_joints.shape != (trajectory.n_samples, robot.n_actuated):
        raise ServoModelError(
            f"joint angles have shape {q_joints.shape}; expected "
            f"({trajectory.n_samples}, {robot.n_actuated})"
        )
    placements = planned_placements
    if placements is None:
        placements = planned_stance_placements(robot, trajectory)
    model, data = robot.model, robot.model.createData()
    frames = [robot.link_frame_ids[foot.link] for foot in robot.feet]
    right = stance_is_right(trajectory.contacts)
    out = with_joint_angles(robot, trajectory.q, q_joints)
    for k in range(len(out)):
        pin.forwardKinematics(model, data, out[k])
        T_world_foot = pin.updateFramePlacement(model, data, frames[int(right[k])])
        correction = placements[k] * T_world_foot.inverse()
        out[k, :7] = pin.SE3ToXYZQUAT(correction * pin.XYZQUATToSE3(out[k, :7]))
    return out


def base_roll_pitch(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Roll and pitch [rad], shape (T,), of the floating base of configurations q (T, nq).

    ZYX (yaw–pitch–roll) Euler angles of R_world_base = Rz(yaw)·Ry(pitch)·Rx(roll), as
    pinocchio's `rpy.matrixToRpy` and a typical IMU report them: roll = atan2(R21, R22),
    pitch = atan2(−R20, √(R00² + R10²)). Neither depends on the heading (yaw).
    """
    x, y, z, w = (q[:, 3 + i] for i in range(4))
    norm2 = x * x + y * y + z * z + w * w
    r20 = 2.0 * (x * z - y * w) / norm2
    r21 = 2.0 * (y * z + x * w) / norm2
    r22 = 1.0 - 2.0 * (x * x + y * y) / norm2
    r00 = 1.0 - 2.0 * (y * y + z * z) / norm2
    r10 = 2.0 * (x * y + z * w) / norm2
    return np.arctan2(r21, r22), np.arctan2(-r20, np.hypot(r00, r10))


def torso_attitude(
    robot: RobotModel, trajectory: Trajectory, q_joints_actual: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(roll, pitch) [rad], shape (T,) each, of the root link in the world (ZYX convention, see
    `base_roll_pitch`) when the joints are at `q_joints_actual` (T, n_actuated) and the stance
    foot is where the plan has it (`grounded_configurations`). For the planned joint angles
    this is the plan's own base roll and pitch."""
    return base_roll_pitch(grounded_configurations(robot, trajectory, q_joints_actual))


@dataclasses.dataclass(frozen=True, eq=False)
class Prediction:
    """A plan, its servo commands, and what the robot does with and without compensation."""

    joint_names: tuple[str, ...]
    t: np.ndarray
    """Sample times [s], shape (T,)."""
    tau_Nm: np.ndarray
    """Torque feed-forward [N·m], shape (T, n)."""
    q_plan_rad: np.ndarray
    """Planned joint angles [rad], shape (T, n)."""
    q_cmd_rad: np.ndarray
    """Compensated servo commands (eq 7 / eq 23) [rad], shape (T, n)."""
    q_actual_uncompensated_rad: np.ndarray
    """Predicted joint angles when the plan is sent as it is (q_cmd = q) [rad], shape (T, n)."""
    q_actual_compensated_rad: np.ndarray
    """Predicted joint angles when `q_cmd_rad` is sent [rad], shape (T, n)."""
    q_world_uncompensated: np.ndarray
    """Whole-robot configurations (T, nq) of the uncompensated robot, stance foot as planned."""
    q_world_compensated: np.ndarray
    """Whole-robot configurations (T, nq) of the compensated robot, stance foot as planned."""
    roll_planned_rad: np.ndarray
    pitch_planned_rad: np.ndarray
    roll_uncompensated_rad: np.ndarray
    pitch_uncompensated_rad: np.ndarray
    roll_compensated_rad: np.ndarray
    pitch_compensated_rad: np.ndarray
    """Torso (root link) roll and pitch in the world [rad], shape (T,) each (ZYX)."""

    @classmethod
    def of(
        cls,
        joint_names: tuple[str, ...],
        t: np.ndarray,
        tau_Nm: np.ndarray,
        q_plan_rad: np.ndarray,
        q_cmd_rad: np.ndarray,
        planned_attitude: tuple[np.ndarray, np.ndarray],
        uncompensated: tuple[np.ndarray, ...],
        compensated: tuple[np.ndarray, ...],
    ) -> Prediction:
        """A prediction from the plan's (roll, pitch) and, without and with compensation, the
        servos' (joint angles, grounded configurations, roll, pitch)."""
        q_unc, world_unc, roll_unc, pitch_unc = uncompensated
        q_comp, world_comp, roll_comp, pitch_comp = compensated
        return cls(
            joint_names=joint_names,
            t=t,
            tau_Nm=tau_Nm,
            q_plan_rad=q_plan_rad,
            q_cmd_rad=q_cmd_rad,
            q_actual_uncompensated_rad=q_unc,
            q_actual_compensated_rad=q_comp,
            q_world_uncompensated=world_unc,
            q_world_compensated=world_comp,
            roll_planned_rad=planned_attitude[0],
            pitch_planned_rad=planned_attitude[1],
            roll_uncompensated_rad=roll_unc,
            pitch_uncompensated_rad=pitch_unc,
            roll_compensated_rad=roll_comp,
            pitch_compensated_rad=pitch_comp,
        )

    def attitude_errors_deg(self) -> dict[str, float]:
        """Largest |roll − planned roll| and |pitch − planned pitch| [°], without and with."""

        def worst(actual: np.ndarray, planned: np.ndarray) -> float:
            return math.degrees(float(np.max(np.abs(actual - planned))))

        return {
            "roll_uncompensated": worst(self.roll_uncompensated_rad, self.roll_planned_rad),
            "pitch_uncompensated": worst(self.pitch_uncompensated_rad, self.pitch_planned_rad),
            "roll_compensated": worst(self.roll_compensated_rad, self.roll_planned_rad),
            "pitch_compensated": worst(self.pitch_compensated_rad, self.pitch_planned_rad),
        }


def predict(
    robot: RobotModel,
    trajectory: Trajectory,
    tau_Nm: np.ndarray,
    comp_params: CompensationParams,
    servo: ServoModel,
    planned_placements: list[pin.SE3] | None = None,
) -> Prediction:
    """Commands and predicted motion of a plan on compliant servos, with and without
    compensation, grounded with pinocchio sample by sample and nothing cached (the reference
    `Predictor` is checked against; a slider uses `Predictor`). `tau_Nm` (T, n_actuated) follows the robot's joint order; coefficients and
    servos may name a subset of the joints (the others are uncompensated / rigid).
    `planned_placements` (from `planned_stance_placements`, which depends on the plan only)
    saves recomputing them when only the coefficients or servos change."""
    check_inputs(robot, trajectory, tau_Nm)
    tau = np.asarray(tau_Nm, dtype=float)
    params = comp_params.for_joints(robot.joint_names)
    servos = servo.for_joints(robot.joint_names)
    q_plan = joint_angles(robot, trajectory.q)
    q_cmd = compensated_command(q_plan, tau, params)
    q_unc = servo_response(q_plan, tau, servos)
    q_comp = servo_response(q_cmd, tau, servos)
    placements = planned_placements
    if placements is None or len(placements) != trajectory.n_samples:
        placements = planned_stance_placements(robot, trajectory)

    def grounded(q_joints: np.ndarray) -> tuple[np.ndarray, ...]:
        world = grounded_configurations(robot, trajectory, q_joints, placements)
        return (q_joints, world, *base_roll_pitch(world))

    return Prediction.of(
        robot.joint_names,
        trajectory.t,
        tau,
        q_plan,
        q_cmd,
        base_roll_pitch(trajectory.q),
        grounded(q_unc),
        grounded(q_comp),
    )


def check_inputs(robot: RobotModel, trajectory: Trajectory, tau_Nm: np.ndarray) -> None:
    if tuple(trajectory.joint_names) != robot.joint_names:
        raise ServoModelError(
            f"trajectory {trajectory.name!r} was made for other joints than {robot.name}'s"
        )
    tau = np.asarray(tau_Nm)
    if tau.shape != (trajectory.n_samples, robot.n_actuated):
        raise ServoModelError(
            f"torques have shape {tau.shape}; expected ({trajectory.n_samples}, "
            f"{robot.n_actuated}): one per sample and actuated joint"
        )


def command_configuration(
    robot: RobotModel, trajectory: Trajectory, prediction: Prediction, k: int
) -> np.ndarray:
    """The whole robot (nq,) at sample k with its joints at the servo commands and its stance
    foot where the plan puts it: what the robot would look like if the servos reached the
    command. One sample at a time (the studio's command ghost follows the timeline)."""
    k = int(np.clip(k, 0, trajectory.n_samples - 1))
    planned = trajectory.q[k]
    q = with_joint_angles(robot, planned[None, :], prediction.q_cmd_rad[k][None, :])[0]
    foot = stance_link(robot, trajectory.contacts[k])
    data = robot.model.createData()
    return anchor_on_foot(robot, q, foot, robot.link_placements(planned, data)[foot], data)
