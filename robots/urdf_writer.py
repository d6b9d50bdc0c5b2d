"""Small URDF writer for the built-in robots, with inertias of solid primitives.

The built-in robots are generated from the papers' numbers by the builders in
`robots/<name>/build.py`; this module holds what they share: solid-body inertias
(closed form, about the body's centre of mass), serial leg chains with the right leg's
limits mirrored from the left's, a total-mass check, and an XML writer that emits links,
joints and the studio's loop-closure declarations.

Frames follow REP 103: x forward, y left, z up. Lengths in metres, masses in kilograms,
angles in radians.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Iterable, Mapping
from xml.sax.saxutils import quoteattr

import numpy as np


@dataclasses.dataclass(frozen=True)
class Shape:
    """A primitive solid, placed in its link frame.

    kind is "box" (size = x, y, z extents), "cylinder" (size = radius, length; axis along
    the shape's local z) or "sphere" (size = radius,).
    """

    kind: str
    size: tuple[float, ...]
    xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rgba: tuple[float, float, float, float] = (0.6, 0.6, 0.65, 1.0)

    def inertia_about_com(self, mass_kg: float) -> np.ndarray:
        """3x3 inertia [kg·m²] of a solid of this shape and mass about its own centre, in the shape frame."""
        if self.kind == "box":
            x, y, z = self.size
            return mass_kg / 12.0 * np.diag([y * y + z * z, x * x + z * z, x * x + y * y])
        if self.kind == "cylinder":
            r, h = self.size
            side = mass_kg * (3.0 * r * r + h * h) / 12.0
            return np.diag([side, side, 0.5 * mass_kg * r * r])
        if self.kind == "sphere":
            (r,) = self.size
            return np.eye(3) * 0.4 * mass_kg * r * r
        raise ValueError(f"unknown shape kind {self.kind!r}; use box, cylinder or sphere")

    def geometry_xml(self) -> str:
        if self.kind == "box":
            return f'<box size="{_fmt(self.size)}"/>'
        if self.kind == "cylinder":
            return f'<cylinder radius="{self.size[0]:.6g}" length="{self.size[1]:.6g}"/>'
        return f'<sphere radius="{self.size[0]:.6g}"/>'


def rpy_to_matrix(rpy: tuple[float, float, float]) -> np.ndarray:
    """Rotation matrix of URDF roll-pitch-yaw angles (R = Rz(yaw) Ry(pitch) Rx(roll))."""
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


@dataclasses.dataclass
class Link:
    """A link whose mass is spread over its shapes in proportion to their volumes.

    If mass_kg is zero the link is a massless frame (no <inertial>).
    """

    name: str
    mass_kg: float
    shapes: list[Shape] = dataclasses.field(default_factory=list)

    def inertial(self) -> tuple[np.ndarray, np.ndarray]:
        """Centre of mass [m] and inertia about it [kg·m²], both in the link frame."""
        if not self.shapes:
            raise ValueError(
                f"link {self.name!r} has mass {self.mass_kg:g} kg but no shapes to spread it over;"
                " give it shapes, or mass 0 for a massless frame"
            )
        volumes = np.array([_volume(s) for s in self.shapes])
        masses = self.mass_kg * volumes / volumes.sum()
        com = sum(m * np.array(s.xyz) for m, s in zip(masses, self.shapes, strict=True))
        com = np.asarray(com) / self.mass_kg
        inertia = np.zeros((3, 3))
        for m, s in zip(masses, self.shapes, strict=True):
            rot = rpy_to_matrix(s.rpy)
            d = np.array(s.xyz) - com
            inertia += rot @ s.inertia_about_com(m) @ rot.T + m * (
                d @ d * np.eye(3) - np.outer(d, d)
            )
        return com, inertia


@dataclasses.dataclass(frozen=True)
class Joint:
    """A URDF joint. kind is "revolute" or "fixed"; limits in rad, N·m, rad/s."""

    name: str
    parent: str
    child: str
    kind: str = "revolute"
    xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    axis: tuple[float, float, float] = (0.0, 1.0, 0.0)
    lower: float = 0.0
    upper: float = 0.0
    effort_Nm: float = 0.0
    velocity_rad_s: float = 0.0


@dataclasses.dataclass(frozen=True)
class LoopClosure:
    """A closed kinematic chain cut open at a joint: the origins of link_a and link_b coincide.

    passive_joints are the unactuated joints of the loop (the studio does not make sliders
    for them; IK solves them).
    """

    name: str
    link_a: str
    link_b: str
    passive_joints: tuple[str, ...]


def mirrored_limits(
    axis: tuple[float, float, float], lower: float, upper: float
) -> tuple[float, float]:
    """Right-side limits of a left-side joint, mirrored through the sagittal (x-z) plane.

    A mirror maps rotations about x and z to their opposites and keeps rotations about y.
    """
    if abs(axis[1]) > 0.5:
        return lower, upper
    return -upper, -lower


def serial_chain(
    side_name: str,
    parent: str,
    left_joints: Iterable[tuple[str, str, tuple[float, float, float], float, float, float]],
    *,
    origins: Mapping[str, tuple[float, float, float]],
    link_masses_kg: Mapping[str, float],
    link_shapes: Mapping[str, list[Shape]],
    velocity_rad_s: float,
    sole_drop_m: float,
) -> tuple[list[Link], list[Joint]]:
    """Links and joints of a serial leg hanging from `parent`, ending in a massless sole frame.

    left_joints lists the chain of the left leg from the top: (joint, child link, axis,
    lower [rad], upper [rad], effort [N·m]). Names get the prefix `<side_name>_`; any side
    but "left" gets mirrored limits (mirrored_limits). origins maps each joint to its origin
    in the parent link frame, link_masses_kg and link_shapes each link to its mass and shapes.
    The last link carries a massless link `<side_name>_sole`, fixed sole_drop_m below it
    (joint `<side_name>_sole_fixed`).
    """
    links, joints = [], []
    for joint_name, link_name, axis, lower, upper, effort_Nm in left_joints:
        if side_name != "left":
            lower, upper = mirrored_limits(axis, lower, upper)
        child = f"{side_name}_{link_name}"
        links.append(Link(child, link_masses_kg[link_name], link_shapes[link_name]))
        joints.append(
            Joint(
                f"{side_name}_{joint_name}",
                parent,
                child,
                xyz=origins[joint_name],
                axis=axis,
                lower=lower,
                upper=upper,
                effort_Nm=effort_Nm,
                velocity_rad_s=velocity_rad_s,
            )
        )
        parent = child
    sole = f"{side_name}_sole"
    links.append(Link(sole, 0.0))
    joints.append(Joint(f"{sole}_fixed", parent, sole, kind="fixed", xyz=(0.0, 0.0, -sole_drop_m)))
    return links, joints


def both_legs(
    leg: Callable[[str], tuple[list[Link], list[Joint]]],
) -> tuple[list[Link], list[Joint]]:
    """Links and joints of leg("left") followed by those of leg("right")."""
    links, joints = leg("left")
    right_links, right_joints = leg("right")
    return links + right_links, joints + right_joints


def check_total_mass(links: Iterable[Link], expected_kg: float, source: str) -> None:
    """Raise ValueError unless the link masses sum to expected_kg (the number given by source)."""
    total_kg = sum(link.mass_kg for link in links)
    if not math.isclose(total_kg, expected_kg, abs_tol=1e-9):
        raise ValueError(f"link masses sum to {total_kg} kg, {source} says {expected_kg} kg")


def write_urdf(
    robot_name: str,
    links: list[Link],
    joints: list[Joint],
    loops: list[LoopClosure] = (),  # type: ignore[assignment]
    comment: str = "",
) -> str:
    """URDF text for the given links, joints and loop closures (a studio extension element)."""
    out = ['<?xml version="1.0"?>']
    if comment:
        out.append(f"<!-- {comment} -->")
    out.append(f"<robot name={quoteattr(robot_name)}>")
    for link in links:
        out.append(f"  <link name={quoteattr(link.name)}>")
        if link.mass_kg > 0.0:
            com, inertia = link.inertial()
            i = inertia
            out.append("    <inertial>")
            out.append(f'      <origin xyz="{_fmt(com)}" rpy="0 0 0"/>')
            out.append(f'      <mass value="{link.mass_kg:.6g}"/>')
            out.append(
                f'      <inertia ixx="{i[0, 0]:.6g}" ixy="{i[0, 1]:.6g}" ixz="{i[0, 2]:.6g}"'
                f' iyy="{i[1, 1]:.6g}" iyz="{i[1, 2]:.6g}" izz="{i[2, 2]:.6g}"/>'
            )
            out.append("    </inertial>")
        for tag in ("visual", "collision"):
            for shape in link.shapes:
                out.append(f"    <{tag}>")
                out.append(f'      <origin xyz="{_fmt(shape.xyz)}" rpy="{_fmt(shape.rpy)}"/>')
                out.append(f"      <geometry>{shape.geometry_xml()}</geometry>")
                if tag == "visual":
                    out.append(
                        f'      <material name=""><color rgba="{_fmt(shape.rgba)}"/></material>'
                    )
                out.append(f"    </{tag}>")
        out.append("  </link>")
    for joint in joints:
        out.append(f"  <joint name={quoteattr(joint.name)} type={quoteattr(joint.kind)}>")
        out.append(f'    <origin xyz="{_fmt(joint.xyz)}" rpy="{_fmt(joint.rpy)}"/>')
        out.append(f"    <parent link={quoteattr(joint.parent)}/>")
        out.append(f"    <child link={quoteattr(joint.child)}/>")
        if joint.kind != "fixed":
            out.append(f'    <axis xyz="{_fmt(joint.axis)}"/>')
            out.append(
                f'    <limit lower="{joint.lower:.6g}" upper="{joint.upper:.6g}"'
                f' effort="{joint.effort_Nm:.6g}" velocity="{joint.velocity_rad_s:.6g}"/>'
            )
        out.append("  </joint>")
    for loop in loops:
        out.append(
            f"  <loop_closure name={quoteattr(loop.name)} link_a={quoteattr(loop.link_a)}"
            f" link_b={quoteattr(loop.link_b)} passive_joints={quoteattr(' '.join(loop.passive_joints))}/>"
        )
    out.append("</robot>")
    return "\n".join(out) + "\n"


def _volume(shape: Shape) -> float:
    if shape.kind == "box":
        return float(np.prod(shape.size))
    if shape.kind == "cylinder":
        return float(np.pi * shape.size[0] ** 2 * shape.size[1])
    return float(4.0 / 3.0 * np.pi * shape.size[0] ** 3)


def _fmt(values) -> str:
    return " ".join(f"{float(v):.6g}" for v in values)
