"""A MuJoCo model (MJCF text) made from the studio's own robot, not by hand.

The MJCF mirrors the pinocchio model joint by joint, so the two have the same dynamics:

- one MuJoCo body per pinocchio joint, placed at `model.jointPlacements[j]` in its parent's
  frame (pinocchio has already merged fixed-joint children into their parent body);
- its inertial element is `model.inertias[j]` exactly: mass m, centre of mass c (the lever)
  and the 3×3 rotational inertia about c, in the joint frame (`fullinertia`);
- revolute / continuous joints become hinges, prismatic ones slides, about the same axis and
  with the same position limits; a floating base becomes a free joint;
- each declared loop `<loop_closure link_a link_b>` becomes a `connect` equality between two
  sites at the origins of link_a and link_b (the origins must coincide);
- each foot's sole rectangle (`Foot.sole_corners_m`) becomes a box of `SOLE_THICKNESS_M`
  whose bottom face is the sole: the feet touch the floor by their soles only;
- every other link collides with the floor by its URDF collision shapes, or a box or capsule
  fitted to its visual geometry (`link_geoms`; `links_collide`), so a fallen robot lies on
  its torso, knees or arms instead of sinking through the floor; with `hulls=True` every
  link's collision (else visual) meshes add their convex hull instead (the feet's too);
- a floor plane with Coulomb friction μ (0.6 by default, as the paper's whole-body QP).

Geoms collide with the floor only (no self-collision). The servos' reflected rotor inertia
is each actuated joint's `armature`, their back-EMF damping its `damping` (integrated
implicitly, so it stays stable at any stiffness; a run writes its servo law's D over it,
`ServoLaw.set_joint_dynamics`); the rest of the servo law acts through
`qfrc_applied` in the step loop (`app.core.simulation.servo_law`). This module uses pinocchio; the step loop
(`engine`) needs only the `SimModel` it returns, which pickles (worker processes).
"""

from __future__ import annotations

import dataclasses
import math
from xml.sax.saxutils import quoteattr

import numpy as np
import pinocchio as pin

from app.core.quaternions import matrix_to_wxyz
from app.core.robot.model import RobotModel
from app.core.simulation.errors import SimulationInputError
from app.core.simulation.link_geoms import convex_hull, link_geoms
from app.core.simulation.servo_law import servo_damping_Nms_per_rad
from app.core.simulation.sim_model import SimModel

FLOOR_FRICTION = 0.6
"""Default floor friction coefficient μ (the whole-body QP's friction pyramids use 0.6)."""
SOLE_THICKNESS_M = 0.01
MIN_SOLE_SIDE_M = 0.005
"""A sole rectangle narrower than this on either side cannot carry the robot."""
MIN_MASS_KG, MIN_INERTIA_KGM2 = 1e-6, 1e-10
"""Massless moving bodies get these (MuJoCo refuses zero mass on a moving body); noted."""
LIMIT_ABOVE = 1e3
"""Position limits at or beyond this magnitude [rad or m] count as none."""


@dataclasses.dataclass(frozen=True)
class SimOptions:
    """How the robot is turned into a MuJoCo model, and how commands reach the servos."""

    friction: float = FLOOR_FRICTION
    """Floor-sole Coulomb friction coefficient μ."""
    hulls: bool = False
    """Add the convex hull of every link's meshes as collision geometry (slower), the
    feet's too, instead of `links_collide`'s shapes."""
    links_collide: bool = True
    """Every link not on a foot collides with the floor (`link_geoms`); False: the soles
    only (the model before, for comparisons)."""
    armature_kgm2: float = 0.01
    """Reflected rotor inertia of each servo [kg·m²], added on every actuated joint's
    diagonal of the mass matrix (a hobby servo's rotor times its gear ratio squared is
    0.005–0.05 kg·m²; MuJoCo Menagerie's Robotis OP3 uses 0.045)."""
    timestep_s: float = 0.001
    """Physics time step [s] (the servo loop runs at this rate too)."""
    command_hold: str = "zoh"
    """"zoh": each command is held until the next one arrives (a 100 Hz staircase);
    "linear": the set point ramps from one command to the next."""


def _f(values) -> str:
    return " ".join(repr(float(x)) for x in np.ravel(values))


def _pose(placement: pin.SE3) -> str:
    return f'pos="{_f(placement.translation)}" quat="{_f(matrix_to_wxyz(placement.rotation))}"'


def _joint_xml(model: pin.Model, jid: int, name: str, armature: float, damping: float) -> str:
    joint = model.joints[jid]
    kind = joint.shortname()
    attr = f"name={quoteattr(name)}"
    if kind == "JointModelFreeFlyer":
        return f"<freejoint {attr}/>"
    if kind.startswith(("JointModelRevoluteUnbounded", "JointModelRUB")):
        axis = _axis(joint, kind)
        return f'<joint {attr} type="hinge" axis="{_f(axis)}" limited="false" armature="{armature!r}" damping="{damping!r}"/>'
    if kind.startswith(("JointModelR", "JointModelRevolute")):
        jtype = "hinge"
    elif kind.startswith(("JointModelP", "JointModelPrismatic")):
        jtype = "slide"
    else:
        raise SimulationInputError(
            f"joint {name!r} is a {kind} joint, which the simulation does not support; "
            "use revolute, continuous or prismatic joints"
        )
    lo, hi = model.lowerPositionLimit[joint.idx_q], model.upperPositionLimit[joint.idx_q]
    limit = 'limited="false"'
    if np.isfinite(lo) and np.isfinite(hi) and lo < hi and max(abs(lo), abs(hi)) < LIMIT_ABOVE:
        limit = f'limited="true" range="{float(lo)!r} {float(hi)!r}"'
    axis = _axis(joint, kind)
    return (
        f'<joint {attr} type="{jtype}" axis="{_f(axis)}" {limit} armature="{armature!r}" '
        f'damping="{damping!r}"/>'
    )


def _axis(joint, kind: str) -> np.ndarray:
    for suffix, axis in (("X", (1, 0, 0)), ("Y", (0, 1, 0)), ("Z", (0, 0, 1))):
        if kind.endswith(suffix) and "Unaligned" not in kind:
            return np.array(axis, dtype=float)
    return np.asarray(joint.extract().axis, dtype=float)


def _inertial_xml(inertia: pin.Inertia, name: str, notes: list[str]) -> str:
    mass = float(inertia.mass)
    full = np.array(inertia.inertia, dtype=float)
    if mass < MIN_MASS_KG:
        notes.append(f"body {name!r} has no mass; simulated with {MIN_MASS_KG:g} kg")
        mass, full = MIN_MASS_KG, np.eye(3) * MIN_INERTIA_KGM2
    moments = np.linalg.eigvalsh(full)
    if moments[0] < MIN_INERTIA_KGM2:
        notes.append(f"body {name!r} has a principal inertia below {MIN_INERTIA_KGM2:g} kg·m²")
        full = full + np.eye(3) * MIN_INERTIA_KGM2
    elif moments[0] + moments[1] < moments[2] * (1.0 - 1e-9):
        notes.append(
            f"body {name!r} has an impossible inertia (principal moments {moments[0]:.3g} + "
            f"{moments[1]:.3g} < {moments[2]:.3g}); MuJoCo balances it"
        )
    return (
        f'<inertial pos="{_f(inertia.lever)}" mass="{mass!r}" fullinertia="'
        f'{_f([full[0, 0], full[1, 1], full[2, 2], full[0, 1], full[0, 2], full[1, 2]])}"/>'
    )


def _sole_box(corners_j: np.ndarray, side: str) -> tuple[str, str]:
    """The sole box and the sole-centre site, in the joint frame, from the 4 corners there."""
    u, v = corners_j[1] - corners_j[0], corners_j[3] - corners_j[0]
    lu, lv = np.linalg.norm(u), np.linalg.norm(v)
    if min(lu, lv) < MIN_SOLE_SIDE_M:
        raise SimulationInputError(
            f"the {side} foot has no sole geometry ({lu * 1e3:.1f} × {lv * 1e3:.1f} mm); give the "
            "foot link a collision or visual shape with a flat bottom"
        )
    normal = np.cross(u, v)
    normal /= np.linalg.norm(normal)
    R = np.column_stack([u / lu, np.cross(normal, u / lu), normal])
    centre = corners_j.mean(axis=0)
    box = pin.SE3(R, centre + 0.5 * SOLE_THICKNESS_M * normal)
    size = [0.5 * lu, 0.5 * lv, 0.5 * SOLE_THICKNESS_M]
    geom = (
        f'<geom name="{side}_sole" type="box" size="{_f(size)}" {_pose(box)} '
        f'contype="0" conaffinity="1" condim="3" group="1" mass="0"/>'
    )
    site = f'<site name="{side}_sole_centre" {_pose(pin.SE3(R, centre))}/>'
    return geom, site


def _hull_geoms(robot: RobotModel, jid: int, name: str) -> tuple[list[str], list[str]]:
    """(assets, geoms): the convex hull of the meshes of every link carried by joint jid."""
    model = robot.model
    links = [f.name for f in model.frames if f.parentJoint == jid and f.type == pin.BODY]
    assets: list[str] = []
    geoms: list[str] = []
    for link in links:
        own = [m for m in robot.meshes if m.link == link]
        role = "collision" if any(m.role == "collision" for m in own) else "visual"
        frame = model.frames[robot.link_frame_ids[link]].placement.homogeneous
        points = [
            (frame @ m.T_link_mesh)[:3, :3] @ m.mesh.vertices.T + (frame @ m.T_link_mesh)[:3, 3:4]
            for m in own
            if m.role == role and len(m.mesh.vertices) >= 4
        ]
        if not points:
            continue
        hull = convex_hull(np.concatenate(points, axis=1).T)
        if hull is None:  # flat point sets have no hull: the link gets none
            continue
        mesh_name = f"hull_{len(assets)}_{name}"
        assets.append(
            f"<mesh name={quoteattr(mesh_name)} vertex={quoteattr(_f(hull.vertices))} "
            f"face={quoteattr(' '.join(str(int(i)) for i in np.ravel(hull.faces)))}/>"
        )
        geoms.append(
            f'<geom type="mesh" mesh={quoteattr(mesh_name)} contype="0" conaffinity="1" '
            'condim="3" group="2" mass="0"/>'
        )
    return assets, geoms


def build_sim_model(robot: RobotModel, options: SimOptions | None = None) -> SimModel:
    """The robot as MJCF (module docstring). Raises SimulationInputError for what cannot be
    simulated: unsupported joint kinds, a foot without sole geometry, bad options."""
    options = options or SimOptions()
    if not (math.isfinite(options.friction) and options.friction > 0.0):
        raise SimulationInputError(f"floor friction is {options.friction}; give μ > 0")
    if not (math.isfinite(options.armature_kgm2) and options.armature_kgm2 >= 0.0):
        raise SimulationInputError(f"armature is {options.armature_kgm2}; give a value ≥ 0")
    if options.command_hold not in ("zoh", "linear"):
        raise SimulationInputError(
            f"command hold {options.command_hold!r}; give 'zoh' (hold) or 'linear' (ramp)"
        )
    if not (1e-5 <= options.timestep_s <= 0.01):
        raise SimulationInputError(f"time step {options.timestep_s} s; give 1e-5 … 0.01 s")
    model = robot.model
    names = [f"j{jid}_{model.names[jid]}" for jid in range(model.njoints)]
    children: dict[int, list[int]] = {}
    for jid in range(1, model.njoints):
        children.setdefault(model.parents[jid], []).append(jid)
    actuated = set(robot.joint_names)
    damping_of = {
        joint.name: servo_damping_Nms_per_rad(joint.effort, joint.velocity)
        for joint in robot.joints
    }
    notes: list[str] = []
    extras: dict[int, list[str]] = {}
    assets: list[str] = []
    for foot in robot.feet:
        frame = model.frames[robot.link_frame_ids[foot.link]]
        corners = (frame.placement.rotation @ foot.sole_corners_m.T).T + frame.placement.translation
        geom, site = _sole_box(corners, foot.side)
        extras.setdefault(frame.parentJoint, []).extend([geom, site])
    for i, loop in enumerate(robot.tree.loops):
        for end, link in (("a", loop.link_a), ("b", loop.link_b)):
            frame = model.frames[robot.link_frame_ids[link]]
            extras.setdefault(frame.parentJoint, []).append(
                f'<site name="loop{i}_{end}" {_pose(frame.placement)}/>'
            )
    if options.hulls:
        for jid in range(1, model.njoints):
            mesh_assets, geoms = _hull_geoms(robot, jid, names[jid])
            assets += mesh_assets
            extras.setdefault(jid, []).extend(geoms)
    elif options.links_collide:
        on_feet = {
            j
            for foot in robot.feet
            for j in _subtree(model, model.frames[robot.link_frame_ids[foot.link]].parentJoint)
        }
        for jid in range(1, model.njoints):
            if jid not in on_feet:
                mesh_assets, geoms = link_geoms(robot, jid, names[jid])
                assets += mesh_assets
                extras.setdefault(jid, []).extend(geoms)

    def body(jid: int) -> str:
        armature = options.armature_kgm2 if model.names[jid] in actuated else 0.0
        damping = damping_of.get(model.names[jid], 0.0)
        parts = [
            f"<body name={quoteattr(names[jid])} {_pose(model.jointPlacements[jid])}>",
            _inertial_xml(model.inertias[jid], model.names[jid], notes),
            _joint_xml(model, jid, model.names[jid], armature, damping),
            *extras.get(jid, []),
            *(body(child) for child in children.get(jid, [])),
            "</body>",
        ]
        return "".join(parts)

    if not robot.floating_base and extras.get(0):
        raise SimulationInputError("a foot is fixed to the world; there is nothing to simulate")
    loops = "".join(
        f'<connect site1="loop{i}_a" site2="loop{i}_b" solref="0.002 1"/>'
        for i in range(len(robot.tree.loops))
    )
    xml = (
        f'<mujoco model={quoteattr(robot.name)}><compiler angle="radian" autolimits="true" balanceinertia="true"/>'
        f'<option timestep="{options.timestep_s!r}" integrator="implicitfast"/>'
        f"<asset>{''.join(assets)}</asset>"
        '<default><geom friction="' + f'{options.friction!r} 0.005 0.0001"/></default>'
        '<worldbody><geom name="floor" type="plane" size="0 0 1" contype="1" conaffinity="0"/>'
        + "".join(body(jid) for jid in children.get(0, []))
        + f"</worldbody><equality>{loops}</equality></mujoco>"
    )
    return _index(robot, xml, names, tuple(notes))


def _subtree(model: pin.Model, jid: int) -> list[int]:
    """Joint jid and every joint below it (pinocchio numbers children after their parent)."""
    members = [jid]
    for child in range(jid + 1, model.njoints):
        if model.parents[child] in members:
            members.append(child)
    return members


def _index(robot: RobotModel, xml: str, names: list[str], notes: tuple[str, ...]) -> SimModel:
    import mujoco

    model = robot.model
    try:
        mj = mujoco.MjModel.from_xml_string(xml)
    except ValueError as error:
        raise SimulationInputError(f"MuJoCo refuses the model of {robot.name}: {error}") from None
    scalar: list[tuple[int, int]] = []
    continuous: list[tuple[int, int]] = []
    dofs: list[tuple[int, int]] = []
    for jid in range(1, model.njoints):
        joint = model.joints[jid]
        if joint.shortname() == "JointModelFreeFlyer":
            continue
        mj_joint = mj.joint(model.names[jid])
        adr_q, adr_v = int(mj_joint.qposadr[0]), int(mj_joint.dofadr[0])
        (continuous if joint.nq == 2 else scalar).append((joint.idx_q, adr_q))
        dofs.append((joint.idx_v, adr_v))
    actuated_q = [int(mj.joint(name).qposadr[0]) for name in robot.joint_names]
    actuated_v = [int(mj.joint(name).dofadr[0]) for name in robot.joint_names]

    def subtree(jid: int) -> tuple[str, ...]:
        return tuple(names[j] for j in _subtree(model, jid))

    feet = tuple(
        subtree(model.frames[robot.link_frame_ids[foot.link]].parentJoint) for foot in robot.feet
    )
    root_jid = 1 if robot.floating_base else 0
    link_of_joint: dict[int, str] = {}
    for frame in model.frames:  # a joint's child link is the first body frame it carries
        if frame.type == pin.FrameType.BODY and frame.parentJoint not in link_of_joint:
            link_of_joint[frame.parentJoint] = frame.name
    return SimModel(
        robot_name=robot.name,
        xml=xml,
        floating_base=robot.floating_base,
        nq_pin=model.nq,
        nv_pin=model.nv,
        joint_names=robot.joint_names,
        actuated_qpos=np.array(actuated_q, dtype=np.int64),
        actuated_dof=np.array(actuated_v, dtype=np.int64),
        pin_scalar_q=np.array(scalar, dtype=np.int64).reshape(-1, 2),
        pin_continuous_q=np.array(continuous, dtype=np.int64).reshape(-1, 2),
        pin_dof=np.array(dofs, dtype=np.int64).reshape(-1, 2),
        sole_geoms=("left_sole", "right_sole"),
        sole_sites=("left_sole_centre", "right_sole_centre"),
        foot_bodies=(feet[0], feet[1]),
        root_body=names[root_jid] if root_jid else "world",
        notes=notes,
        body_links=tuple(
            (names[jid], link_of_joint[jid])
            for jid in range(1, model.njoints)
            if jid in link_of_joint
        ),
    )
