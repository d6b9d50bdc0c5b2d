"""Reducing a floating-base biped to the sagittal plane: which bodies, where, how heavy.

The planar joints are the *pitch joints of the legs*: joints on the path from the base to a
sole whose axis, at the neutral configuration (every joint at zero), is parallel to the world's
y axis — whatever the joint's own frame or its URDF axis (Roban S14's hip pitch follows a 45°
tilted joint; SigmaBan's joints all turn about their own z). Every other joint (hip roll and
yaw, arms, head, waist) is locked at zero and the bodies it carries are merged into the nearest
planar ancestor (or the base) with pinocchio's exact 3-D inertia algebra.
A leg without a hip pitch joint but with a spherical hip (three co-located joints whose axes
span 3-D, Roban S14) gets a *virtual* hip pitch joint instead (hip_group.py).

Each planar body gets a *planar frame*: at its joint's origin, parallel to the world frame at
the neutral configuration. A planar joint whose axis is ±y turns its body's planar frame by
θ_body = θ_parent ± q about y (the sign is `axis_sign`). Each body is then projected: mass, CoM
(x, z) in its planar frame and the pitch inertia I_yy about the CoM; for motions in the plane
the kinetic and potential energies of the 3-D bodies are exactly those of the projections
(lateral offsets and products of inertia do not enter).
The contact points are the mid-points of the rear (heel) and front (toe) edges of each sole.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pinocchio as pin

from app.core.collocation.hip_group import find_hip_group
from app.core.errors import StudioError
from app.core.robot.model import RobotModel

BASE_DOF = 3
"""x [m], z [m], pitch [rad] of the floating base."""
AXIS_TOLERANCE = 1e-6
"""|1 − |axis·ŷ|| below which a joint axis counts as a pitch axis (URDF rounding)."""
MIN_LEG_PITCH_JOINTS = 3
"""Hip pitch, knee and ankle pitch: a stance foot held flat at a foothold takes three."""


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
    """Joint origin in the parent body's planar frame (x, z) [m]."""
    joint_pitch_rad: float
    """Fixed pitch of the planar frame in the parent's planar frame [rad] (0: planar frames are
    parallel at the neutral configuration)."""
    mass_kg: float
    com_xz_m: np.ndarray
    """CoM in the body's planar frame (x, z) [m]."""
    inertia_yy: float
    """Pitch inertia about the CoM [kg·m²]."""
    axis_sign: float = 1.0
    """+1 if the joint turns about +y at the neutral configuration, −1 about −y."""


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
    hip_groups: dict[str, tuple[int, ...]] = dataclasses.field(default_factory=dict)
    """Virtual pitch joints: name -> the pinocchio joint ids of its hip group (hip_group.py)."""


def pitch_of(rotation: np.ndarray, what: str) -> float:
    """The angle of a rotation about y, refusing any other rotation."""
    if abs(rotation[1, 1] - 1.0) > AXIS_TOLERANCE:
        raise PlanarModelError(f"{what} is rotated out of the sagittal plane; it cannot be planar")
    return float(np.arctan2(rotation[0, 2], rotation[0, 0]))


def _leg_chain(model: pin.Model, joint_id: int) -> list[int]:
    """Joint ids from the base's first child down to `joint_id`."""
    chain = []
    while joint_id > 1:
        chain.append(joint_id)
        joint_id = model.parents[joint_id]
    return chain[::-1]


def world_axes(model: pin.Model) -> tuple[np.ndarray, np.ndarray]:
    """(axis (njoints, 3), origin (njoints, 3)) of every 1-DOF joint in the world frame at the
    neutral configuration (rows of other joints are zero)."""
    data = model.createData()
    q0 = pin.neutral(model)
    pin.computeJointJacobians(model, data, q0)
    axes = np.zeros((model.njoints, 3))
    origins = np.array([data.oMi[j].translation for j in range(model.njoints)])
    for jid in range(2, model.njoints):
        if model.joints[jid].nv == 1:
            J = pin.getJointJacobian(model, data, jid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
            axes[jid] = J[3:, model.joints[jid].idx_v]
    return axes, origins


def reduce_to_plane(robot: RobotModel, planar_joints: tuple[str, ...] | None = None) -> PlanarTree:
    """The planar tree of a robot; `planar_joints` defaults to the legs' pitch joints."""
    model = robot.model
    if not robot.floating_base:
        raise PlanarModelError(f"{robot.name} has a fixed base; the gait planner needs legs")
    if robot.passive_joints:
        raise PlanarModelError(
            f"{robot.name} has closed kinematic loops (passive joints "
            f"{', '.join(robot.passive_joints[:3])}…); the gait planner handles open legs only"
        )
    axes, origins = world_axes(model)
    feet = {foot.side: foot for foot in robot.feet}
    if set(feet) != {"left", "right"}:
        raise PlanarModelError(f"{robot.name} does not have a left and a right foot; it needs two")
    chains = {
        side: _leg_chain(model, model.frames[robot.link_frame_ids[foot.link]].parentJoint)
        for side, foot in feet.items()
    }
    if chains["left"][-1:] == chains["right"][-1:]:
        raise PlanarModelError(f"{robot.name}: both feet hang on one leg; the planner needs two")

    def is_pitch(jid: int) -> bool:
        return model.joints[jid].nq == 1 and abs(abs(axes[jid][1]) - 1.0) < AXIS_TOLERANCE

    if planar_joints is None:
        picked = {jid for chain in chains.values() for jid in chain if is_pitch(jid)}
    else:
        picked = set()
        for name in planar_joints:
            if not model.existJointName(name):
                raise PlanarModelError(f"{robot.name} has no joint {name}")
            jid = model.getJointId(name)
            if not is_pitch(jid):
                raise PlanarModelError(f"joint {name} does not turn about y; it cannot be planar")
            picked.add(jid)
    groups: dict[str, tuple[int, ...]] = {}
    for side, chain in chains.items():
        pitch = [model.names[j] for j in chain if j in picked]
        first = next((i for i, j in enumerate(chain) if j in picked), len(chain))
        group = find_hip_group(model, chain[:first], axes, origins)
        if planar_joints is None and len(pitch) < MIN_LEG_PITCH_JOINTS and group is not None:
            name = "+".join(model.names[j] for j in group)  # a virtual hip pitch joint
            groups[name] = group
            pitch.insert(0, name)
        if len(pitch) < MIN_LEG_PITCH_JOINTS:
            found = ", ".join(pitch) if pitch else "none"
            raise PlanarModelError(
                f"the {side} leg of {robot.name} has {len(pitch)} pitch joint(s) ({found}); the "
                "gait planner needs hip pitch, knee and ankle pitch (axes along y when standing)"
            )
    first_of = {group[0]: name for name, group in groups.items()}
    names = tuple(
        first_of.get(j, model.names[j])
        for j in range(2, model.njoints)
        if j in picked or j in first_of
    )
    bodies, owner = _bodies(model, names, axes, origins, groups)

    points = []
    legs = {}
    data = model.createData()
    pin.framesForwardKinematics(model, data, pin.neutral(model))
    for side in ("left", "right"):
        foot = feet[side]
        frame_id = robot.link_frame_ids[foot.link]
        body, owner_jid = owner[model.frames[frame_id].parentJoint]
        T = pin.SE3(np.eye(3), -origins[owner_jid]) * data.oMf[frame_id]
        pitch_of(T.rotation, f"sole frame {foot.link} (the {side} foot)")
        corners = foot.sole_corners_m
        for x_edge in (corners[:, 0].min(), corners[:, 0].max()):
            p = T.act(corners[np.abs(corners[:, 0] - x_edge) < 1e-9].mean(axis=0))
            points.append((body, np.array([p[0], p[2]])))
        chain = []
        while body > 0:
            chain.append(BASE_DOF + body - 1)
            body = bodies[body].parent
        legs[side] = np.array(chain[::-1])
    if len(legs["left"]) != len(legs["right"]):
        raise PlanarModelError(
            f"the legs of {robot.name} have different numbers of pitch joints "
            f"({len(legs['left'])} left, {len(legs['right'])} right)"
        )
    return PlanarTree(names, bodies, tuple(points), legs, groups)


def _bodies(
    model: pin.Model,
    names: tuple[str, ...],
    axes: np.ndarray,
    origins: np.ndarray,
    groups: dict[str, tuple[int, ...]],
) -> tuple[tuple[PlanarBody, ...], dict[int, tuple[int, int]]]:
    """Merge locked joints' bodies into their planar ancestor, then project on the plane.
    Also returns, per pinocchio joint, (planar body, pinocchio joint of that body). The
    bodies of a hip group all move with its virtual joint (see hip_group.py)."""
    in_group = {j: (name, group[0]) for name, group in groups.items() for j in group}
    data = model.createData()
    pin.forwardKinematics(model, data, pin.neutral(model))
    owner: dict[int, tuple[int, int]] = {1: (0, 1)}
    inertias = [model.inertias[1].copy()]
    placements: list[tuple[int, np.ndarray, str, float]] = [(-1, np.zeros(3), "base", 1.0)]
    for jid in range(2, model.njoints):
        name, parent = model.names[jid], model.parents[jid]
        parent_body, parent_jid = owner[parent]
        # The joint's frame in its owner's planar frame (world-parallel, at the owner's origin).
        T_planar_joint = pin.SE3(data.oMi[jid].rotation, origins[jid] - origins[parent_jid])
        if jid in in_group and in_group[jid][1] != jid:  # a later joint of a hip group
            body, first = owner[in_group[jid][1]]
            owner[jid] = (body, first)
            T_group_joint = pin.SE3(data.oMi[jid].rotation, origins[jid] - origins[first])
            inertias[body] = inertias[body] + T_group_joint.act(model.inertias[jid])
        elif jid in in_group:  # the first joint of a hip group: the virtual joint's body
            owner[jid] = (len(inertias), jid)
            placements.append(
                (parent_body, origins[jid] - origins[parent_jid], in_group[jid][0], 1.0)
            )
            inertias.append(pin.SE3(data.oMi[jid].rotation, np.zeros(3)).act(model.inertias[jid]))
        elif name in names:
            owner[jid] = (len(inertias), jid)
            sign = float(np.sign(axes[jid][1]))
            placements.append((parent_body, origins[jid] - origins[parent_jid], name, sign))
            inertias.append(pin.SE3(data.oMi[jid].rotation, np.zeros(3)).act(model.inertias[jid]))
        else:
            owner[jid] = (parent_body, parent_jid)
            inertias[parent_body] = inertias[parent_body] + T_planar_joint.act(model.inertias[jid])
    bodies = tuple(
        PlanarBody(
            name=name,
            parent=parent,
            joint_xz_m=np.array([offset[0], offset[2]]),
            joint_pitch_rad=0.0,
            mass_kg=float(inertia.mass),
            com_xz_m=np.array([inertia.lever[0], inertia.lever[2]]),
            inertia_yy=float(inertia.inertia[1, 1]),
            axis_sign=sign,
        )
        for (parent, offset, name, sign), inertia in zip(placements, inertias, strict=True)
    )
    return bodies, owner
