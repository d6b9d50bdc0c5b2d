"""A checked URDF as records (UrdfTree: links, joints, inertials, geometry, declared loops)
and URDF's roll-pitch-yaw convention both ways. Made by app.core.robot.urdf_xml.parse_urdf,
written back by app.core.robot.urdf_write.canonical_urdf.
"""

from __future__ import annotations

import dataclasses

import numpy as np


@dataclasses.dataclass(frozen=True)
class Geometry:
    """One <visual> or <collision> element, in its link's frame."""

    link: str
    role: str
    """"visual" or "collision"."""
    kind: str
    """"box", "cylinder", "sphere" or "mesh"."""
    T_link_geom: np.ndarray
    """Placement of the geometry in the link frame, 4x4 homogeneous."""
    size: tuple[float, ...] = ()
    """box: x y z [m]; cylinder: radius, length [m]; sphere: radius [m]; mesh: scale x y z."""
    uri: str = ""
    """mesh filename as written in the URDF (relative, package:// or file://)."""
    rgba: tuple[float, float, float, float] | None = None


@dataclasses.dataclass(frozen=True)
class Inertial:
    mass_kg: float
    com_m: np.ndarray
    """Centre of mass in the link frame [m], shape (3,)."""
    inertia_kgm2: np.ndarray
    """Inertia about the centre of mass, in the inertial frame [kg·m²], shape (3, 3)."""


@dataclasses.dataclass(frozen=True)
class JointElement:
    name: str
    kind: str
    parent: str
    child: str
    T_parent_joint: np.ndarray
    axis: np.ndarray
    lower: float | None
    upper: float | None
    effort: float | None
    velocity: float | None


@dataclasses.dataclass(frozen=True)
class LoopElement:
    """A declared loop closure: the origins of link_a and link_b coincide."""

    name: str
    link_a: str
    link_b: str
    passive_joints: tuple[str, ...]


@dataclasses.dataclass(frozen=True)
class UrdfTree:
    """A checked URDF: one root, a tree of links and joints, geometry, loops."""

    name: str
    root: str
    links: tuple[str, ...]
    joints: dict[str, JointElement]
    inertials: dict[str, Inertial]
    geometries: tuple[Geometry, ...]
    loops: tuple[LoopElement, ...]

    def children_of(self, link: str) -> list[JointElement]:
        return [j for j in self.joints.values() if j.parent == link]

    def parent_joint(self, link: str) -> JointElement | None:
        for joint in self.joints.values():
            if joint.child == link:
                return joint
        return None


def rpy_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """URDF fixed-axis roll, pitch, yaw [rad] -> rotation matrix Rz(yaw) Ry(pitch) Rx(roll)."""
    cr, sr = np.cos(roll), np.sin(roll)
    cp, sp = np.cos(pitch), np.sin(pitch)
    cy, sy = np.cos(yaw), np.sin(yaw)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def matrix_rpy(rotation: np.ndarray) -> np.ndarray:
    """URDF roll, pitch, yaw [rad] of a rotation matrix (inverse of rpy_matrix)."""
    pitch = np.arcsin(-np.clip(rotation[2, 0], -1.0, 1.0))
    if abs(rotation[2, 0]) < 1.0 - 1e-12:
        roll = np.arctan2(rotation[2, 1], rotation[2, 2])
        yaw = np.arctan2(rotation[1, 0], rotation[0, 0])
    else:  # gimbal lock: put everything in yaw
        roll = 0.0
        yaw = np.arctan2(-rotation[0, 1], rotation[1, 1])
    return np.array([roll, pitch, yaw])
