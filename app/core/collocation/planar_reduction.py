"""Reducing a floating-base biped to the sagittal plane: which bodies, where, how heavy.

Every joint that is not a pitch joint (axis y) is locked at zero and the bodies it carries are
merged into the nearest pitch-joint body (or the base) with pinocchio's exact 3-D inertia
algebra. Each body is then projected: mass, CoM (x, z) in its joint frame, and the pitch inertia
Iyy about its CoM. For motions in the plane the kinetic and potential energies of the 3-D bodies
are exactly those of the projections (lateral offsets and products of inertia do not enter).
The contact points are the mid-points of the rear (heel) and front (toe) edges of each sole.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pinocchio as pin

from app.core.errors import StudioError
from app.core.robot.model import RobotModel

BASE_DOF = 3
"""x [m], z [m], pitch [rad] of the floating base."""


class PlanarModelError(StudioError):
    """The robot cannot be reduced to the sagittal plane (a joint or foot is not aligned)."""


@dataclasses.dataclass(frozen=True)
class PlanarBody:
    """One rigid body of the planar tree; body 0 is the floating base."""

    name: str
    """The pinocchio joint that moves it ("base" for the floating base)."""
    parent: int
    """Index of the parent body, -1 for the base."""
    joint_xz_m: np.ndarray
    """Joint origin in the parent body's frame (x, z) [m]."""
    joint_pitch_rad: float
    """Fixed pitch of the joint frame in the parent frame [rad]."""
    mass_kg: float
    com_xz_m: np.ndarray
    """CoM in the body frame (x, z) [m]."""
    inertia_yy: float
    """Pitch inertia about the CoM [kg·m²]."""


@dataclasses.dataclass(frozen=True)
class PlanarTree:
    joint_names: tuple[str, ...]
    """The planar joints, in pinocchio order; q = [x, z, pitch, these]."""
    bodies: tuple[PlanarBody, ...]
    """Base, then one body per planar joint (same order)."""
    contact_points: tuple[tuple[int, np.ndarray], ...]
    """(body, (x, z) in its frame) of left heel, left toe, right heel, right toe."""
    leg_joints: dict[str, np.ndarray]
    """Indices into q of each leg's planar joints, hip to ankle, by side."""


def pitch_of(rotation: np.ndarray, what: str) -> float:
    """The angle of a rotation about y, refusing any other rotation."""
    if abs(rotation[1, 1] - 1.0) > 1e-9:
        raise PlanarModelError(f"{what} is rotated out of the sagittal plane; it cannot be planar")
    return float(np.arctan2(rotation[0, 2], rotation[0, 0]))


def _is_pitch_joint(model: pin.Model, name: str) -> bool:
    return bool(model.joints[model.getJointId(name)].shortname() == "JointModelRY")


def reduce_to_plane(robot: RobotModel, planar_joints: tuple[str, ...] | None = None) -> PlanarTree:
    """The planar tree of a robot; `planar_joints` defaults to every actuated y-axis joint."""
    model = robot.model
    if not robot.floating_base:
        raise PlanarModelError(f"{robot.name} has a fixed base; the gait planner needs legs")
    if planar_joints is None:
        planar_joints = tuple(n for n in robot.joint_names if _is_pitch_joint(model, n))
    names = tuple(n for n in model.names[2:] if n in set(planar_joints))
    for name in names:
        if not _is_pitch_joint(model, name):
            raise PlanarModelError(f"joint {name} does not turn about y; it cannot be planar")
    bodies = _bodies(model, names)

    def frame_in_body(frame_id: int) -> tuple[int, pin.SE3]:
        """(body, the frame's placement in that body's joint frame), locked joints at 0."""
        frame = model.frames[frame_id]
        T, jid = frame.placement, frame.parentJoint
        while jid > 1 and model.names[jid] not in names:
            T = model.jointPlacements[jid] * T
            jid = model.parents[jid]
        return (0 if jid <= 1 else 1 + names.index(model.names[jid])), T

    points = []
    legs = {}
    for foot in robot.feet:
        body, T = frame_in_body(robot.link_frame_ids[foot.link])
        pitch_of(T.rotation, f"sole frame {foot.link}")
        corners = foot.sole_corners_m
        for x_edge in (corners[:, 0].min(), corners[:, 0].max()):
            p = T.act(corners[np.abs(corners[:, 0] - x_edge) < 1e-9].mean(axis=0))
            points.append((body, np.array([p[0], p[2]])))
        chain = []
        while body > 0:
            chain.append(BASE_DOF + body - 1)
            body = bodies[body].parent
        legs[foot.side] = np.array(chain[::-1])
    if len(legs["left"]) != len(legs["right"]) or not len(legs["left"]):
        raise PlanarModelError("the legs have different numbers of pitch joints")
    return PlanarTree(names, bodies, tuple(points), legs)


def _bodies(model: pin.Model, names: tuple[str, ...]) -> tuple[PlanarBody, ...]:
    """Merge locked joints' bodies into their planar ancestor, then project on the plane."""
    owner = {1: 0}  # pinocchio joint id -> planar body index
    offset = {1: pin.SE3.Identity()}  # joint frame in its owner's frame (locked joints at 0)
    inertias = [model.inertias[1].copy()]
    placements: list[tuple[int, pin.SE3, str]] = [(-1, pin.SE3.Identity(), "base")]
    for jid in range(2, model.njoints):
        name, parent = model.names[jid], model.parents[jid]
        T_owner_joint = offset[parent] * model.jointPlacements[jid]
        if name in names:
            owner[jid] = len(inertias)
            offset[jid] = pin.SE3.Identity()
            placements.append((owner[parent], T_owner_joint, name))
            inertias.append(model.inertias[jid].copy())
        else:
            if model.joints[jid].nq != 1:
                raise PlanarModelError(f"joint {name} is not a 1-DOF joint; cannot lock it")
            owner[jid] = owner[parent]
            offset[jid] = T_owner_joint
            merged = inertias[owner[parent]] + T_owner_joint.act(model.inertias[jid])
            inertias[owner[parent]] = merged
    return tuple(
        PlanarBody(
            name=name,
            parent=parent,
            joint_xz_m=np.array([T.translation[0], T.translation[2]]),
            joint_pitch_rad=pitch_of(T.rotation, f"joint {name}"),
            mass_kg=float(inertia.mass),
            com_xz_m=np.array([inertia.lever[0], inertia.lever[2]]),
            inertia_yy=float(inertia.inertia[1, 1]),
        )
        for (parent, T, name), inertia in zip(placements, inertias, strict=True)
    )
