"""RobotModel: a loaded robot — pinocchio model, actuated joints, feet, meshes, loops.

Configuration vectors are pinocchio's: for a floating-base robot q = [base xyz (3), base
quaternion xyzw (4), joint coordinates], v = [base twist (6), joint velocities].
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pinocchio as pin

from app.core.robot.feet import Foot
from app.core.robot.meshes import LinkMesh, MissingMesh
from app.core.robot.urdf_xml import UrdfTree


@dataclasses.dataclass(frozen=True)
class ActuatedJoint:
    name: str
    kind: str
    """"revolute", "continuous" or "prismatic"."""
    idx_q: int
    idx_v: int
    lower: float
    """Lower position limit [rad or m]; -pi for a continuous joint."""
    upper: float
    effort: float | None
    """Effort limit [N·m or N], None when the URDF gives none (or zero)."""
    velocity: float | None
    """Velocity limit [rad/s or m/s], None when the URDF gives none (or zero)."""
    limb: str
    """Group shown in the UI: "Left leg", "Right leg", "Left arm", "Right arm", "Torso", "Head", "Other"."""


@dataclasses.dataclass(frozen=True)
class RobotModel:
    """Everything the studio knows about one loaded robot. Immutable once loaded."""

    name: str
    source: Path
    tree: UrdfTree
    model: pin.Model
    floating_base: bool
    joints: tuple[ActuatedJoint, ...]
    passive_joints: tuple[str, ...]
    feet: tuple[Foot, Foot]
    """(left, right)."""
    meshes: tuple[LinkMesh, ...]
    missing_meshes: tuple[MissingMesh, ...]
    link_frame_ids: dict[str, int]
    q_neutral: np.ndarray
    """Standing configuration: joints at zero (or mid-range when zero is outside the limits),
    base raised so the lowest sole point touches z = 0."""

    @property
    def n_actuated(self) -> int:
        return len(self.joints)

    @property
    def mass_kg(self) -> float:
        return float(sum(inertia.mass for inertia in self.model.inertias))

    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(joint.name for joint in self.joints)

    def joint_angles(self, q: np.ndarray) -> np.ndarray:
        """Actuated joint positions [rad or m] of a configuration, in `joints` order."""
        out = np.empty(len(self.joints))
        for i, joint in enumerate(self.joints):
            if joint.kind == "continuous":
                out[i] = np.arctan2(q[joint.idx_q + 1], q[joint.idx_q])
            else:
                out[i] = q[joint.idx_q]
        return out

    def with_joint_angles(self, q: np.ndarray, angles: np.ndarray) -> np.ndarray:
        """A copy of q whose actuated joints are set to `angles` [rad or m]."""
        q = np.array(q, dtype=float)
        for joint, angle in zip(self.joints, angles, strict=True):
            if joint.kind == "continuous":
                q[joint.idx_q : joint.idx_q + 2] = np.cos(angle), np.sin(angle)
            else:
                q[joint.idx_q] = angle
        return q

    def link_placements(self, q: np.ndarray, data: pin.Data) -> dict[str, np.ndarray]:
        """T_world_link (4x4) of every link at configuration q."""
        pin.framesForwardKinematics(self.model, data, q)
        return {link: data.oMf[fid].homogeneous for link, fid in self.link_frame_ids.items()}

    def com(self, q: np.ndarray, data: pin.Data) -> np.ndarray:
        """Whole-body centre of mass in the world frame [m], shape (3,)."""
        return np.array(pin.centerOfMass(self.model, data, q))

    def bounds_m(self, q: np.ndarray, data: pin.Data) -> tuple[np.ndarray, np.ndarray]:
        """Axis-aligned (lower, upper) corners [m] of the visual geometry at configuration q."""
        placements = self.link_placements(q, data)
        points = [
            (placements[m.link] @ m.T_link_mesh)[:3, :3] @ m.mesh.bounds.T
            + (placements[m.link] @ m.T_link_mesh)[:3, 3:4]
            for m in self.meshes
            if m.role == "visual" and m.link in placements
        ]
        if not points:
            origins = np.array([T[:3, 3] for T in placements.values()])
            return origins.min(axis=0), origins.max(axis=0)
        stacked = np.concatenate(points, axis=1)
        return stacked.min(axis=1), stacked.max(axis=1)

    def foot(self, side: str) -> Foot:
        return self.feet[0] if side == "left" else self.feet[1]


def neutral_joint_positions(model: pin.Model) -> np.ndarray:
    """pin.neutral with every bounded joint clamped into its limits (mid-range if 0 is outside)."""
    q = pin.neutral(model)
    lower, upper = model.lowerPositionLimit, model.upperPositionLimit
    for jid in range(1, model.njoints):
        joint = model.joints[jid]
        if joint.nq != 1:
            continue
        i = joint.idx_q
        lo, hi = lower[i], upper[i]
        if np.isfinite(lo) and np.isfinite(hi) and lo <= hi and not lo <= q[i] <= hi:
            q[i] = 0.5 * (lo + hi)
    return q
