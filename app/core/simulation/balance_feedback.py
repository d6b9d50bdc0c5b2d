"""An optional balance feedback of the kind a servo robot's firmware runs: the torso's roll and
pitch from an IMU to offsets on the stance legs' ankle and hip commands. Off by default; a
run with it says so in its verdict ("stays up with balance feedback").

Once per command sample (10 ms at the motion's 100 Hz, as firmware runs), before the
sample's command is sent, the IMU on the root body (the torso) reads its roll φ and pitch θ
(ZYX, as `recording` and the plan's `base_roll_pitch`) from the body's orientation, and its
rates from the gyro (the root's angular velocity in its own frame, MuJoCo's free-joint
velocity, turned into roll/pitch rates). Against the plan's torso at that sample:

    e = (φ − φ_plan, θ − θ_plan),   ė = (φ̇ − φ̇_plan, θ̇ − θ̇_plan)       [rad], [rad/s]
    Δq_j = clip(Kp_j · (a_j · e) + Kd_j · (a_j · ė), ±Δq_max)           per fed joint j

a_j = (a_x, a_y) the joint's axis in the torso's frame at the motion's first pose (its roll
and pitch components: a pitch joint has a ≈ (0, ±1), so each joint answers its own tilt, with
its URDF's sign). Kp_j, Kd_j are the ankle's or the hip's gains. The fed joints are, on each
leg, the ankle's two joints (the two next to the foot: the roll-most and pitch-most axes)
and the hip's roll and pitch (among the three joints next to the torso), on the legs the
plan holds on the floor at that sample (a swinging leg gets none). With that foot fixed on
the floor, +Δq_j on a joint turns everything above it by −Δq_j about a_j: the offsets turn
the torso back towards the plan's attitude by (Kp_ankle + Kp_hip)·e, the ankles by moving
the whole body over its feet (the ankle strategy, which also stiffens the ankle servos
against gravity's tipping by the factor 1 + Kp), the hips by turning the torso on its legs.
Commands stay within the joint limits. Between two samples the servos hold the corrected
command as they hold any (the physics steps on in C, `blocks`).

Defaults (`BalanceGains`): ankles Kp 1.0, Kd 0.05 s; hips Kp 0.5, Kd 0.02 s; |Δq| ≤ 10°,
chosen on servo_biped and Roban S14 (docs/simulation.md): a soft-servo stand that falls
without the feedback stands with it; higher gains on the 10 ms loop start to shake.

The spec (`BalanceFeedback`) is built where pinocchio is (`balance_feedback`); the loop part
(`Balancer`) is numpy only, for the simulation's worker processes.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING

import numpy as np

from app.core.simulation.errors import SimulationInputError

if TYPE_CHECKING:
    from app.core.motions.trajectory import Trajectory
    from app.core.robot.model import RobotModel

LABEL = "balance feedback"
"""How a run with the feedback is named ("stays up with balance feedback")."""
AXIS_MIN = 0.5
"""A joint counts as a roll (pitch) joint when its axis is within 60° of the torso's x (y)."""


@dataclasses.dataclass(frozen=True)
class BalanceGains:
    """The feedback's gains (module docstring): Δq = Kp·e + Kd·ė on each fed joint's axis."""

    ankle_kp: float = 1.0
    """Ankle offset per torso tilt error [rad/rad]."""
    ankle_kd: float = 0.05
    """Ankle offset per torso tilt rate error [rad/(rad/s)] = [s]."""
    hip_kp: float = 0.5
    """Hip offset per torso tilt error [rad/rad]."""
    hip_kd: float = 0.02
    """Hip offset per torso tilt rate error [s]."""
    max_offset_deg: float = 10.0
    """Largest offset on one joint [°] (saturation)."""

    def __post_init__(self) -> None:
        for field in dataclasses.fields(self):
            value = getattr(self, field.name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0.0):
                raise SimulationInputError(
                    f"balance feedback {field.name} = {value!r}; give a finite number ≥ 0"
                )
        if not 0.0 < self.max_offset_deg <= 45.0:
            raise SimulationInputError(
                f"balance feedback max_offset_deg = {self.max_offset_deg:g}; give 0 < … ≤ 45°"
            )

    def text(self) -> str:
        """The gains in one line, as the panel and the CLI show them."""
        return (
            f"ankles Kp {self.ankle_kp:g}, Kd {self.ankle_kd:g} s; hips Kp {self.hip_kp:g}, "
            f"Kd {self.hip_kd:g} s; ≤ {self.max_offset_deg:g}° per joint"
        )

    def to_json(self) -> dict[str, float]:
        return {field.name: float(getattr(self, field.name)) for field in dataclasses.fields(self)}


@dataclasses.dataclass(frozen=True, eq=False)
class BalanceFeedback:
    """One run's feedback, picklable and numpy only (module docstring)."""

    gains: BalanceGains
    columns: np.ndarray
    """Actuated joint (command column) of each fed joint, shape (m,)."""
    legs: np.ndarray
    """Leg of each fed joint, 0 left, 1 right, shape (m,)."""
    names: tuple[str, ...]
    """Each fed joint's name and role, e.g. "left_ankle_pitch (ankle)"."""
    axis_xy: np.ndarray
    """Each fed joint's axis in the torso frame at the first pose: its (x, y) components,
    shape (m, 2)."""
    kp: np.ndarray
    """Proportional gain of each fed joint [rad/rad], shape (m,)."""
    kd: np.ndarray
    """Derivative gain of each fed joint [s], shape (m,)."""
    stance: np.ndarray
    """(T, 2) bool: the legs (left, right) the plan holds on the floor at each sample."""
    tilt_planned_rad: np.ndarray
    """The plan's torso (roll, pitch) at each sample [rad], shape (T, 2)."""
    rate_planned_rad_s: np.ndarray
    """Their rates [rad/s], shape (T, 2) (central differences)."""
    lower_rad: np.ndarray
    upper_rad: np.ndarray
    """Each actuated joint's limits [rad], shape (n,): commands stay within them."""


def balance_feedback(
    robot: RobotModel,
    trajectory: Trajectory,
    gains: BalanceGains,
    roll_planned_rad: np.ndarray,
    pitch_planned_rad: np.ndarray,
) -> BalanceFeedback:
    """The feedback's spec for `robot` on `trajectory` (SimulationInputError when the legs'
    ankle and hip joints cannot be told apart)."""
    import pinocchio as pin

    model, data = robot.model, robot.model.createData()
    q0 = trajectory.q[0]
    pin.forwardKinematics(model, data, q0)
    pin.computeJointJacobians(model, data, q0)
    R_world_torso = data.oMi[1].rotation
    index = {model.getJointId(j.name): i for i, j in enumerate(robot.joints)}
    chains = []
    for foot in robot.feet:  # actuated joints from the foot up to the torso
        jid, chain = model.frames[robot.link_frame_ids[foot.link]].parentJoint, []
        while jid > 0:
            if jid in index:
                chain.append(index[jid])
            jid = model.parents[jid]
        chains.append(chain)
    shared = set(chains[0]) & set(chains[1])
    columns, legs, names, axes, kp, kd = [], [], [], [], [], []
    for foot, chain in zip(robot.feet, chains, strict=True):
        leg = [j for j in chain if j not in shared]
        if len(leg) < 4:
            raise SimulationInputError(
                f"balance feedback: the {foot.side} leg of {robot.name} has {len(leg)} "
                "actuated joint(s); it needs ankle and hip joints (≥ 4)"
            )
        side = 0 if foot.side == "left" else 1
        for role, group, p, d in (
            ("ankle", leg[:2], gains.ankle_kp, gains.ankle_kd),
            ("hip", leg[-3:], gains.hip_kp, gains.hip_kd),
        ):
            axis_of = {}
            for j in group:
                jid = model.getJointId(robot.joints[j].name)
                J = pin.getJointJacobian(model, data, jid, pin.LOCAL_WORLD_ALIGNED)
                axis = R_world_torso.T @ J[3:, robot.joints[j].idx_v]
                axis_of[j] = axis / max(float(np.linalg.norm(axis)), 1e-12)
            for component in (0, 1):  # the roll-most, then the pitch-most joint
                j = max(axis_of, key=lambda j: abs(axis_of[j][component]))
                if abs(axis_of[j][component]) < AXIS_MIN or j in columns:
                    continue
                columns.append(j)
                legs.append(side)
                names.append(f"{robot.joints[j].name} ({role})")
                axes.append(axis_of[j][:2])
                kp.append(p)
                kd.append(d)
    if not columns:
        raise SimulationInputError(
            f"balance feedback: no ankle or hip joint of {robot.name} turns about the torso's "
            "x or y axis"
        )
    tilt = np.column_stack([roll_planned_rad, pitch_planned_rad]).astype(float)
    rate = np.gradient(np.unwrap(tilt, axis=0), trajectory.dt, axis=0)
    return BalanceFeedback(
        gains=gains,
        columns=np.array(columns, dtype=int),
        legs=np.array(legs, dtype=int),
        names=tuple(names),
        axis_xy=np.array(axes, dtype=float),
        kp=np.array(kp, dtype=float),
        kd=np.array(kd, dtype=float),
        stance=np.asarray(trajectory.contacts, dtype=bool).copy(),
        tilt_planned_rad=tilt,
        rate_planned_rad_s=rate,
        lower_rad=np.array([joint.lower for joint in robot.joints], dtype=float),
        upper_rad=np.array([joint.upper for joint in robot.joints], dtype=float),
    )


def imu_roll_pitch(quat_wxyz: np.ndarray, omega_body: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """What the IMU reports: the torso's (roll, pitch) [rad] from its orientation (w, x, y, z)
    and their rates [rad/s] from the gyro's ω (the body's angular velocity in its own frame):
    φ̇ = ω_x + tan θ (sin φ ω_y + cos φ ω_z), θ̇ = cos φ ω_y − sin φ ω_z (ZYX Euler rates)."""
    w, x, y, z = (float(c) for c in quat_wxyz)  # R's entries (`quaternions.wxyz_to_matrix`)
    n2 = w * w + x * x + y * y + z * z
    r00, r10 = 1.0 - 2.0 * (y * y + z * z) / n2, 2.0 * (x * y + z * w) / n2
    r20, r21 = 2.0 * (x * z - y * w) / n2, 2.0 * (y * z + x * w) / n2
    r22 = 1.0 - 2.0 * (x * x + y * y) / n2
    roll = math.atan2(r21, r22)
    pitch = math.atan2(-r20, math.hypot(r00, r10))
    wx, wy, wz = (float(c) for c in omega_body)
    s, c = math.sin(roll), math.cos(roll)
    rates = (wx + math.tan(pitch) * (s * wy + c * wz), c * wy - s * wz)
    return np.array([roll, pitch]), np.array(rates)


class Balancer:
    """The feedback running in the step loop: `command(k, qpos, qvel, planned)` is the
    command of sample k with the offsets added; `offsets_rad` (T, n) keeps what was added."""

    def __init__(self, feedback: BalanceFeedback, n_samples: int, n_joints: int) -> None:
        self.feedback = feedback
        self.max_offset_rad = math.radians(feedback.gains.max_offset_deg)
        self.offsets_rad = np.zeros((n_samples, n_joints))

    def offsets(self, k: int, qpos: np.ndarray, qvel: np.ndarray) -> np.ndarray:
        """The offsets (n,) [rad] at sample k from the torso's state: MuJoCo's free joint
        (qpos[3:7] its orientation w, x, y, z; qvel[3:6] its angular velocity in its frame)."""
        fb = self.feedback
        tilt, rate = imu_roll_pitch(qpos[3:7], qvel[3:6])
        error = tilt - fb.tilt_planned_rad[k]
        error = (error + math.pi) % (2.0 * math.pi) - math.pi
        rate_error = rate - fb.rate_planned_rad_s[k]
        offset = fb.kp * (fb.axis_xy @ error) + fb.kd * (fb.axis_xy @ rate_error)
        offset = np.clip(offset, -self.max_offset_rad, self.max_offset_rad)
        offset *= fb.stance[k, fb.legs]
        out = np.zeros(len(fb.lower_rad))
        out[fb.columns] = offset
        return out

    def command(
        self, k: int, qpos: np.ndarray, qvel: np.ndarray, planned: np.ndarray, record: bool = True
    ) -> np.ndarray:
        """The planned command (n,) of sample k plus the offsets, within the joint limits;
        `record`: keep the offsets as sample k's (not while settling)."""
        fb, columns = self.feedback, self.feedback.columns
        command = np.array(planned, dtype=float)
        command[columns] = np.clip(
            command[columns] + self.offsets(k, qpos, qvel)[columns],
            fb.lower_rad[columns],
            fb.upper_rad[columns],
        )
        if record:
            self.offsets_rad[k] = command - planned
        return command


def gains_from_pairs(pairs: list[str]) -> BalanceGains:
    """The default gains with NAME=VALUE pairs over them (`simulate --balance-gain`)."""
    names = [field.name for field in dataclasses.fields(BalanceGains)]
    given: dict[str, float] = {}
    for pair in pairs:
        name, sep, value = (part.strip() for part in pair.partition("="))
        if not sep or name not in names:
            raise SimulationInputError(
                f"balance feedback gain {pair!r}: give NAME=VALUE with NAME one of "
                f"{', '.join(names)}"
            )
        try:
            given[name] = float(value)
        except ValueError:
            raise SimulationInputError(
                f"balance feedback gain {name} = {value!r}; give a number"
            ) from None
    return BalanceGains(**given)


def balance_line(gains: BalanceGains, offsets_rad: np.ndarray | None) -> str:
    """The feedback named, with its gains and the largest offset it added."""
    line = f"{LABEL} (IMU → ankles/hips) on: {gains.text()}"
    if offsets_rad is not None and offsets_rad.size:
        line += f"; largest offset {math.degrees(float(np.abs(offsets_rad).max())):.1f}°"
    return line
