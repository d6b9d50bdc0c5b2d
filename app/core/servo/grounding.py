"""Forward kinematics of the two legs over many samples at once, for grounding a robot on its
stance foot (app.core.servo.model).

Grounding only needs, per sample, the stance foot's placement relative to the floating base:
the base then sits at T_world_foot(plan) · T_base_foot(q)⁻¹, whatever the base was. Each leg is
a chain of one-degree-of-freedom joints (revolute, continuous or prismatic), so T_base_foot is a
product of fixed placements and rotations about (or slides along) fixed axes, computed here for
every sample in a handful of numpy operations instead of one pinocchio call per sample. A chain
with any other joint is not handled (`LegChains.of` returns None) and the caller falls back to
pinocchio, sample by sample.
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np
import pinocchio as pin

from app.core.robot.model import RobotModel


@dataclasses.dataclass(frozen=True, eq=False)
class ChainJoint:
    """One joint of a leg: its placement in its parent joint and its motion."""

    placement: np.ndarray
    """T_parent_joint at zero motion, shape (4, 4)."""
    axis: np.ndarray
    """Unit axis in the joint's frame, shape (3,)."""
    idx_q: int
    kind: str
    """"revolute" (angle q[idx_q]), "continuous" (angle atan2(q[idx_q+1], q[idx_q])) or
    "prismatic" (displacement q[idx_q])."""


@dataclasses.dataclass(frozen=True, eq=False)
class LegChains:
    """The joints between the floating base and each foot (left, right)."""

    joints: tuple[tuple[ChainJoint, ...], tuple[ChainJoint, ...]]
    foot_placements: tuple[np.ndarray, np.ndarray]
    """T_joint_foot of each foot's frame in its parent joint, shape (4, 4)."""

    @classmethod
    def of(cls, robot: RobotModel) -> LegChains | None:
        """The robot's two legs, or None when a leg has a joint this module does not handle
        (or the robot has no floating base)."""
        if not robot.floating_base or len(robot.feet) != 2:
            return None
        model = robot.model
        data = model.createData()
        pin.forwardKinematics(model, data, pin.neutral(model))  # fills each joint's subspace
        chains, feet = [], []
        for foot in robot.feet:
            frame = model.frames[robot.link_frame_ids[foot.link]]
            support, j = [], frame.parentJoint
            while j > 1:  # joint 1 is the floating base, 0 the universe
                support.append(j)
                j = model.parents[j]
            if j != 1:
                return None
            chain = []
            for j in reversed(support):
                joint = _chain_joint(model, data, j)
                if joint is None:
                    return None
                chain.append(joint)
            chains.append(tuple(chain))
            feet.append(frame.placement.homogeneous.copy())
        return cls((chains[0], chains[1]), (feet[0], feet[1]))

    def base_to_foot(self, foot: int, q: np.ndarray) -> np.ndarray:
        """T_base_foot of foot 0 (left) or 1 (right) at configurations q (T, nq), (T, 4, 4)."""
        rotation, position = self.base_to_foot_parts(foot, q)
        out = np.zeros((len(q), 4, 4))
        out[:, :3, :3] = np.moveaxis(rotation, 2, 0)
        out[:, :3, 3] = position.T
        out[:, 3, 3] = 1.0
        return out

    def base_to_foot_parts(self, foot: int, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """`base_to_foot` as its rotation R[a, b, k] (3, 3, T) and position p[a, k] (3, T):
        sample-last, the layout the legs' kinematics computes in, so a caller that goes on
        elementwise (the grounding, app.core.servo.predictor) needs no (T, 4, 4) round trip."""
        n = len(q)
        # The rotation as its three columns over all samples, columns[j] = R[:, j] (3, T) (or
        # (3, 1) while it is still the same for every sample): composing with a fixed matrix
        # mixes columns, elementwise over long rows.
        columns = [np.eye(3)[:, j, None] for j in range(3)]
        position = np.zeros((3, 1))
        for joint, step in zip(self.joints[foot], self._steps[foot], strict=True):
            # T ← T · placement · motion(q)
            if step.offset is not None:
                position = position + _combine(step.offset, columns)
            if step.rotation is not None:
                columns = _compose(columns, step.rotation)
            if joint.kind == "prismatic":
                position = position + _combine(joint.axis, columns) * q[:, joint.idx_q]
                continue
            if joint.kind == "continuous":
                angle = np.arctan2(q[:, joint.idx_q + 1], q[:, joint.idx_q])
            else:
                angle = q[:, joint.idx_q]
            sin, cos = np.sin(angle), np.cos(angle)
            if step.about is not None:
                # about a coordinate axis: only the two other columns turn
                i, sign = step.about
                j, k = (i + 1) % 3, (i + 2) % 3
                if sign < 0.0:
                    sin = -sin
                columns = list(columns)
                columns[j], columns[k] = (
                    cos * columns[j] + sin * columns[k],
                    cos * columns[k] - sin * columns[j],
                )
                continue
            # R · Rot(axis, angle) = R + sin·(R K) + (1 − cos)·(R K²)  (Rodrigues)
            cross = _cross_matrix(joint.axis)
            turn, bend = _compose(columns, cross), _compose(columns, cross @ cross)
            columns = [columns[j] + sin * turn[j] + (1.0 - cos) * bend[j] for j in range(3)]
        foot_placement = self.foot_placements[foot]
        rotation = np.empty((3, 3, n))
        for j, column in enumerate(_compose(columns, foot_placement[:3, :3])):
            rotation[:, j] = column
        position = position + _combine(foot_placement[:3, 3], columns)
        return rotation, np.broadcast_to(position, (3, n))

    @functools.cached_property
    def _steps(self) -> tuple[tuple[_Step, ...], tuple[_Step, ...]]:
        """What each joint's placement and axis ask of `base_to_foot_parts`, found once (the
        slider's re-prediction runs the chains a block of samples at a time)."""
        left, right = (tuple(_Step.of(joint) for joint in chain) for chain in self.joints)
        return left, right

    def stance_to_base_parts(
        self, right: np.ndarray, q: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """`stance_to_base` as `base_to_foot_parts` gives it: R (3, 3, T) and p (3, T)."""
        right = np.asarray(right, dtype=bool)
        if right.all() or not right.any():
            return self.base_to_foot_parts(int(right[0]) if len(right) else 0, q)
        rotation, position = np.empty((3, 3, len(q))), np.empty((3, len(q)))
        for foot in (0, 1):
            mask = right == bool(foot)
            rotation[:, :, mask], position[:, mask] = self.base_to_foot_parts(foot, q[mask])
        return rotation, position

    def stance_to_base(self, right: np.ndarray, q: np.ndarray) -> np.ndarray:
        """T_base_foot of each sample's stance foot (right[k] selects the right foot), (T,4,4)."""
        right = np.asarray(right, dtype=bool)
        if right.all() or not right.any():  # one stance foot throughout: no masked copies
            return self.base_to_foot(int(right[0]) if len(right) else 0, q)
        out = np.empty((len(q), 4, 4))
        for foot in (0, 1):
            mask = right == bool(foot)
            out[mask] = self.base_to_foot(foot, q[mask])
        return out


@dataclasses.dataclass(frozen=True)
class _Step:
    """A chain joint as `base_to_foot_parts` applies it: its placement's translation (None when
    zero) and rotation (None when the identity), and the coordinate axis it turns about as
    (index, ±1) (None for another axis)."""

    offset: np.ndarray | None
    rotation: np.ndarray | None
    about: tuple[int, float] | None

    @classmethod
    def of(cls, joint: ChainJoint) -> _Step:
        offset, rotation = joint.placement[:3, 3], joint.placement[:3, :3]
        aligned = np.flatnonzero(joint.axis)
        about = None
        if len(aligned) == 1 and joint.axis[aligned[0]] in (1.0, -1.0):
            about = (int(aligned[0]), float(joint.axis[aligned[0]]))
        return cls(
            offset.copy() if np.any(offset) else None,
            None if np.array_equal(rotation, np.eye(3)) else rotation.copy(),
            about,
        )


def _chain_joint(model: pin.Model, data: pin.Data, j: int) -> ChainJoint | None:
    joint = model.joints[j]
    if joint.nv != 1 or joint.nq not in (1, 2):
        return None
    subspace = np.asarray(data.joints[j].S).reshape(6)
    linear, angular = subspace[:3], subspace[3:]
    placement = model.jointPlacements[j].homogeneous.copy()
    if joint.nq == 2:  # a continuous joint: (cos, sin) of its angle
        if np.any(linear) or not np.isclose(np.linalg.norm(angular), 1.0):
            return None
        return ChainJoint(placement, angular.copy(), joint.idx_q, "continuous")
    if not np.any(linear) and np.isclose(np.linalg.norm(angular), 1.0):
        return ChainJoint(placement, angular.copy(), joint.idx_q, "revolute")
    if not np.any(angular) and np.isclose(np.linalg.norm(linear), 1.0):
        return ChainJoint(placement, linear.copy(), joint.idx_q, "prismatic")
    return None


def _combine(weights: np.ndarray, columns: list[np.ndarray]) -> np.ndarray:
    """Σ_k weights[k]·columns[k]: R·w for a rotation held as its columns (exact zeros of w
    skipped: most placements and axes are aligned)."""
    out: np.ndarray = np.zeros((3, 1))
    for k in range(3):
        if weights[k] != 0.0:
            out = out + weights[k] * columns[k]
    return out


def _compose(columns: list[np.ndarray], matrix: np.ndarray) -> list[np.ndarray]:
    """The columns of R·M for a rotation R held as its columns and a fixed 3×3 M. Plain
    elementwise numpy, so no BLAS threads wake for these small products."""
    return [_combine(matrix[:, j], columns) for j in range(3)]


def _cross_matrix(axis: np.ndarray) -> np.ndarray:
    """K with K·v = axis × v."""
    x, y, z = axis
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def se3_inverse(T: np.ndarray) -> np.ndarray:
    """Inverses of rigid transforms (…, 4, 4)."""
    out = np.zeros_like(T)
    rotation_t = np.swapaxes(T[..., :3, :3], -1, -2)
    out[..., :3, :3] = rotation_t
    out[..., :3, 3] = -(rotation_t @ T[..., :3, 3, None])[..., 0]
    out[..., 3, 3] = 1.0
    return out
