"""The quick estimate fast enough to follow a coefficient slider: `predict` (app.core.servo.model)
for one plan and its torques, with what the coefficients cannot change computed once and the
grounding vectorised a block of samples at a time."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import pinocchio as pin

from app.core.motions.trajectory import Trajectory
from app.core.quaternions import matrices_to_xyzquat, xyzquat_to_matrices
from app.core.robot.model import RobotModel
from app.core.servo.compensation import (
    CompensationParams,
    checked_command,
    compensated_command,
    k_rad_per_Nm,
)
from app.core.servo.grounding import LegChains
from app.core.servo.model import (
    Prediction,
    ServoModel,
    ServoModelError,
    base_roll_pitch,
    check_inputs,
    grounded_configurations,
    joint_angles,
    planned_stance_placements,
    servo_response,
    stance_is_right,
    with_joint_angles,
)

BLOCK_SAMPLES = 8192
"""Samples grounded at a time by `Predictor`: a block's arrays (≈ 200 kB each) stay in a
core's cache, and the blocks are few enough that numpy's per-call cost does not weigh
(measured on 60 000 samples: 2 048 a block is slower than 8 192, the whole motion at once
slower still)."""


class Predictor:
    """`predict` for one plan and its torques, fast enough to follow a coefficient slider.

    What the coefficients cannot change is computed once: the planned joint angles, the plan's
    stance-foot placements and attitude, and (for the last servos asked for) the uncompensated
    prediction. The grounding's forward kinematics runs over all samples at once
    (app.core.servo.grounding) where the legs allow it, else sample by sample as `predict` does.
    The result equals `predict`'s to round-off.
    """

    def __init__(self, robot: RobotModel, trajectory: Trajectory, tau_Nm: np.ndarray) -> None:
        check_inputs(robot, trajectory, tau_Nm)
        if not robot.floating_base:
            raise ServoModelError(
                f"{robot.name} has a fixed base: the torso cannot tilt, there is nothing to predict"
            )
        self.robot, self.trajectory = robot, trajectory
        self.tau = np.asarray(tau_Nm, dtype=float)
        self.q_plan = joint_angles(robot, trajectory.q)
        self.roll_plan, self.pitch_plan = base_roll_pitch(trajectory.q)
        self._finite = bool(np.isfinite(self.q_plan).all() and np.isfinite(self.tau).all())
        self._right = stance_is_right(trajectory.contacts)
        self._chains = LegChains.of(robot)
        self._placements: list[pin.SE3] = []
        # The plan's stance-foot placements in the world, sample-last (R (3, 3, T), p (3, T)).
        self._foot_rotations, self._foot_positions = np.empty((3, 3, 0)), np.empty((3, 0))
        if self._chains is None:
            self._placements = planned_stance_placements(robot, trajectory)
        else:
            placements = xyzquat_to_matrices(trajectory.q[:, :7]) @ self._chains.stance_to_base(
                self._right, trajectory.q
            )
            self._foot_rotations = np.ascontiguousarray(np.moveaxis(placements[:, :3, :3], 0, 2))
            self._foot_positions = np.ascontiguousarray(placements[:, :3, 3].T)
        self._uncompensated: tuple[ServoModel, tuple[np.ndarray, ...]] | None = None
        self._terms: tuple[ServoModel, np.ndarray, np.ndarray] | None = None

    @property
    def vectorised(self) -> bool:
        """Whether the grounding runs over all samples at once (else sample by sample)."""
        return self._chains is not None

    def grounded(self, q_joints: np.ndarray) -> np.ndarray:
        """`grounded_configurations` of this plan for joint angles (T, n)."""
        return self._grounded_attitude(q_joints)[0]

    def _grounded_attitude(
        self, q_joints: np.ndarray | Callable[[slice], np.ndarray]
    ) -> tuple[np.ndarray, ...]:
        """`grounded` and its base's roll and pitch [rad] (`base_roll_pitch`), (T, nq), (T,),
        (T,), for joint angles (T, n) or a function giving those of a slice of samples.
        Vectorised, a block of `BLOCK_SAMPLES` samples at a time: the dozens of elementwise
        passes of the legs' kinematics then stay in the CPU's cache (over a long motion at
        once, each pass streams megabytes from memory)."""
        angles = (lambda rows: q_joints[rows]) if isinstance(q_joints, np.ndarray) else q_joints
        n = self.trajectory.n_samples
        if self._chains is None:
            q_all = angles(slice(0, n))
            out = grounded_configurations(self.robot, self.trajectory, q_all, self._placements)
            return (out, *base_roll_pitch(out))
        out = np.empty((n, self.trajectory.q.shape[1]))
        roll, pitch = np.empty(n), np.empty(n)
        for begin in range(0, n, BLOCK_SAMPLES):
            rows = slice(begin, min(n, begin + BLOCK_SAMPLES))
            block = out[rows]
            with_joint_angles(self.robot, self.trajectory.q[rows], angles(rows), out=block)
            R_foot, p_foot = self._chains.stance_to_base_parts(self._right[rows], block)
            # T_world_base = T_world_foot · T_base_foot⁻¹, elementwise over the samples
            R_world, p_world = self._foot_rotations[:, :, rows], self._foot_positions[:, rows]
            R = [[_dot3(R_world[a], R_foot[b]) for b in range(3)] for a in range(3)]
            position = [p_world[a] - _dot3(R[a], p_foot) for a in range(3)]
            _set_base(block, np.array(R), np.array(position))
            roll[rows] = np.arctan2(R[2][1], R[2][2])  # `base_roll_pitch` of the rotation
            pitch[rows] = np.arctan2(-R[2][0], np.hypot(R[0][0], R[1][0]))
        return out, roll, pitch

    def _compensated(
        self, params: CompensationParams, servos: ServoModel
    ) -> tuple[np.ndarray, ...]:
        """q_cmd (eq 7, 23), the servos' response to it, and its grounding and attitude,
        computed a block of samples at a time (`_grounded_attitude`); plan and torques were
        checked once, each block's commands are."""
        q_cmd, q_comp = np.empty_like(self.tau), np.empty_like(self.tau)
        lag, dead_band = self._servo_terms(servos)
        # eq 7 alone on every joint (no φ, none disabled, the usual slider): `checked_command`'s
        # arithmetic without its passes that would add zeros and keep every column
        k_rad = k_rad_per_Nm(params.k_deg_per_Nm)
        spring_only = bool(np.all(params.enabled)) and not np.any(params.phi_deg)

        def angles(rows: slice) -> np.ndarray:
            if spring_only:
                with np.errstate(over="ignore", invalid="ignore"):  # huge τ: refused below
                    np.multiply(k_rad, self.tau[rows], out=q_comp[rows])
                    np.add(self.q_plan[rows], q_comp[rows], out=q_cmd[rows])
            else:
                q_cmd[rows] = checked_command(self.q_plan[rows], self.tau[rows], params)
            if not np.isfinite(q_cmd[rows]).all():
                servo_response(q_cmd[rows], self.tau[rows], servos)  # raises its error
            # `settled`'s equation, its two terms computed once for these servos
            np.subtract(q_cmd[rows], lag[rows], out=q_comp[rows])
            q_comp[rows] -= dead_band[rows]
            return q_comp[rows]

        return (q_cmd, q_comp, *self._grounded_attitude(angles))

    def _servo_terms(self, servos: ServoModel) -> tuple[np.ndarray, np.ndarray]:
        """c·τ and (b/2)·sign(τ) of `settled` [rad], (T, n) each: the servos' lag and dead
        band along the plan's torques, which a k or φ slider does not change."""
        cached = self._terms
        if cached is None or not _same_servos(cached[0], servos):
            lag = np.deg2rad(servos.compliance_deg_per_Nm) * self.tau
            dead_band = np.deg2rad(0.5 * servos.backlash_deg) * np.sign(self.tau)
            cached = self._terms = (servos, lag, dead_band)
        return cached[1], cached[2]

    def predict(self, comp_params: CompensationParams, servo: ServoModel) -> Prediction:
        params = comp_params.for_joints(self.robot.joint_names)
        servos = servo.for_joints(self.robot.joint_names)
        cached = self._uncompensated
        if cached is not None and _same_servos(cached[0], servos):
            uncompensated = cached[1]
        else:
            q_unc = servo_response(self.q_plan, self.tau, servos)
            uncompensated = (q_unc, *self._grounded_attitude(q_unc))
            self._uncompensated = (servos, uncompensated)
        if self._finite:
            q_cmd, *compensated = self._compensated(params, servos)
        else:
            q_cmd = compensated_command(self.q_plan, self.tau, params)  # its error
            q_comp = servo_response(q_cmd, self.tau, servos)
            compensated = [q_comp, *self._grounded_attitude(q_comp)]
        return Prediction.of(
            self.robot.joint_names,
            self.trajectory.t,
            self.tau,
            self.q_plan,
            q_cmd,
            (self.roll_plan, self.pitch_plan),
            uncompensated,
            tuple(compensated),
        )


def _same_servos(a: ServoModel, b: ServoModel) -> bool:
    """The same compliance and backlash (both laid out on the robot's joints)."""
    return np.array_equal(a.compliance_deg_per_Nm, b.compliance_deg_per_Nm) and np.array_equal(
        a.backlash_deg, b.backlash_deg
    )


def _dot3(
    left: Sequence[np.ndarray] | np.ndarray, right: Sequence[np.ndarray] | np.ndarray
) -> np.ndarray:
    """Σ_j left[j]·right[j] over three rows of samples (T,) each."""
    return left[0] * right[0] + left[1] * right[1] + left[2] * right[2]


def _set_base(q: np.ndarray, rotation: np.ndarray, position: np.ndarray) -> None:
    """Set the floating base of configurations q (T, nq) to rotations (3, 3, T) and positions
    (3, T): pinocchio's xyz and quaternion (`matrices_to_xyzquat`'s, elementwise here while
    every rotation's trace is positive, as an upright base's is)."""
    q[:, :3] = position.T
    trace = rotation[0, 0] + rotation[1, 1] + rotation[2, 2]
    if not (trace > 0.0).all():
        T = np.zeros((len(q), 4, 4))
        T[:, :3, :3] = np.moveaxis(rotation, 2, 0)
        q[:, 3:7] = matrices_to_xyzquat(T)[:, 3:]
        return
    t = np.sqrt(trace + 1.0)
    half = 0.5 / t
    q[:, 6] = 0.5 * t
    q[:, 3] = (rotation[2, 1] - rotation[1, 2]) * half
    q[:, 4] = (rotation[0, 2] - rotation[2, 0]) * half
    q[:, 5] = (rotation[1, 0] - rotation[0, 1]) * half
