"""Load a robot from a built-in name or a URDF path into a RobotModel.

Every failure raises a RobotLoadError whose message says what is wrong and what to do; a
caller that holds a previously loaded robot simply keeps it.

The URDF is read through the input gate (regular file, ≤ 20 MiB, UTF-8 or declared XML). Its
meshes are looked up only where its loader allows: a URDF inside an upload's folder is confined
to that folder however it is opened (by upload or by path), and a `FileAccess` given by the
studio confines both the URDF and its meshes to the allowed folders.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pinocchio as pin

from app.core import input_gate
from app.core.errors import RobotLoadError, UrdfStructureError
from app.core.file_access import FileAccess
from app.core.robot.feet import Foot, find_foot_links, sole_corners
from app.core.robot.limbs import limb_of_joints
from app.core.robot.meshes import load_link_meshes
from app.core.robot.model import ActuatedJoint, RobotModel, neutral_joint_positions
from app.core.robot.packages import PackageResolver
from app.core.robot.uploads import upload_sandbox_of
from app.core.robot.urdf_xml import MOVING_JOINT_TYPES, UrdfTree, canonical_urdf, parse_urdf
from robots.catalogue import BUILTIN_ROBOTS

MAX_URDF_BYTES = input_gate.URDF.max_bytes


def resolve_source(source: str | Path, access: FileAccess | None = None) -> Path:
    """The URDF file behind a built-in robot name or a path (checked against `access` first,
    so nothing is revealed about a path outside the allowed folders)."""
    if isinstance(source, str) and source in BUILTIN_ROBOTS:
        return BUILTIN_ROBOTS[source].urdf_path
    path = Path(source).expanduser()
    if access is not None:
        path = access.check(path)  # resolved: a link swapped in later is not followed out
    if not path.exists():
        names = ", ".join(BUILTIN_ROBOTS)
        raise RobotLoadError(f"{source}: no such file, and not a built-in robot ({names})")
    if path.is_dir():
        urdfs = sorted(path.glob("*.urdf")) + sorted(path.glob("urdf/*.urdf"))
        if len(urdfs) != 1:
            raise RobotLoadError(
                f"{path}: a folder; give the .urdf file inside it ({len(urdfs)} found)"
            )
        path = urdfs[0] if access is None else access.check(urdfs[0])
    if path.suffix.lower() == ".xacro":
        raise RobotLoadError(
            f"{path.name}: a xacro file; expand it first (xacro {path.name} > robot.urdf)"
        )
    return path


def load_robot(
    source: str | Path,
    *,
    package_roots: tuple[Path, ...] = (),
    feet: tuple[str, str] | None = None,
    sandbox: Path | None = None,
    access: FileAccess | None = None,
    progress: Callable[[str], None] | None = None,
) -> RobotModel:
    """Load and check a robot. `feet` names the (left, right) foot links to override detection;
    `sandbox` confines mesh look-ups to a folder (a URDF inside an upload's folder is always
    confined to exactly that whole folder instead, whatever is given); `access` confines the URDF and its meshes to the studio's
    allowed folders (paths typed by a user). `progress` is told each stage as it starts
    ("reading the URDF", "mesh 3 of 25", "finding the feet")."""
    say = progress if progress is not None else (lambda _stage: None)
    path = resolve_source(source, access)
    say("reading the URDF")
    text = input_gate.read_bytes(path, input_gate.URDF, RobotLoadError)
    tree = parse_urdf(text, source=path.name)
    model, floating = _pinocchio_model(tree, path.name)
    passive = tuple(joint for loop in tree.loops for joint in loop.passive_joints)

    link_frame_ids = {}
    for link in tree.links:
        if model.existFrame(link, pin.BODY):
            link_frame_ids[link] = model.getFrameId(link, pin.BODY)

    upload = upload_sandbox_of(path)
    if upload is not None:  # the whole unpacked archive, however the URDF was opened
        sandbox = upload
    resolver = PackageResolver(
        path.parent, package_roots, sandbox, access.allows if access is not None else None
    )
    meshes, missing = load_link_meshes(
        tree.geometries, resolver, lambda done, total: say(f"mesh {done} of {total}")
    )
    say("finding the feet")

    q0 = neutral_joint_positions(model)
    data = model.createData()
    pin.framesForwardKinematics(model, data, q0)
    T_world = {link: data.oMf[fid].homogeneous for link, fid in link_frame_ids.items()}
    left, right = find_foot_links(tree, T_world, feet)
    rigid = {
        foot: [
            link
            for link, fid in link_frame_ids.items()
            if model.frames[fid].parentJoint == model.frames[link_frame_ids[foot]].parentJoint
        ]
        for foot in (left, right)
    }
    corners = {foot: sole_corners(foot, rigid[foot], meshes, T_world) for foot in (left, right)}
    if floating:
        lowest = min(
            float((T_world[foot][:3, :3] @ corners[foot].T + T_world[foot][:3, 3:4])[2].min())
            for foot in (left, right)
        )
        q0[2] -= lowest

    limbs = limb_of_joints(tree, (left, right), T_world)
    joints = tuple(
        _actuated_joint(model, tree, name, limbs[name])
        for name in model.names[1:]
        if name in tree.joints and name not in passive
    )
    return RobotModel(
        name=tree.name,
        source=path,
        tree=tree,
        model=model,
        floating_base=floating,
        joints=joints,
        passive_joints=passive,
        feet=(Foot("left", left, corners[left]), Foot("right", right, corners[right])),
        meshes=tuple(meshes),
        missing_meshes=tuple(missing),
        link_frame_ids=link_frame_ids,
        q_neutral=q0,
    )


def _pinocchio_model(tree: UrdfTree, source: str) -> tuple[pin.Model, bool]:
    floating = tree.root != "world"
    xml = canonical_urdf(tree)
    try:
        model = (
            pin.buildModelFromXML(xml, pin.JointModelFreeFlyer())
            if floating
            else pin.buildModelFromXML(xml)
        )
    except (RuntimeError, ValueError) as exc:
        raise RobotLoadError(f"{source}: pinocchio cannot build the model: {exc}") from None
    mass = sum(inertia.mass for inertia in model.inertias)
    if not mass > 0.0:
        raise UrdfStructureError(
            f"{source}: the robot's total mass is {mass:g} kg; give its links masses"
        )
    return model, floating


def _actuated_joint(model: pin.Model, tree: UrdfTree, name: str, limb: str) -> ActuatedJoint:
    element = tree.joints[name]
    jid = model.getJointId(name)
    joint = model.joints[jid]
    assert element.kind in MOVING_JOINT_TYPES
    if element.kind == "continuous":
        lower, upper = -np.pi, np.pi
    else:
        lower = element.lower if element.lower is not None else -np.pi
        upper = element.upper if element.upper is not None else np.pi

    def positive(value: float | None) -> float | None:
        return value if value is not None and value > 0.0 else None

    return ActuatedJoint(
        name=name,
        kind=element.kind,
        idx_q=joint.idx_q,
        idx_v=joint.idx_v,
        lower=lower,
        upper=upper,
        effort=positive(element.effort),
        velocity=positive(element.velocity),
        limb=limb,
    )
