"""What every link but the feet collides with the floor by (MJCF geoms), so a fallen robot
lies on its links instead of sinking through the floor.

Per link carried by a MuJoCo body that is not on a foot (`mjcf` keeps the feet to their
sole boxes, so standing and walking contacts do not change):

- its URDF `<collision>` shapes as they are: a box, a cylinder (MuJoCo's and URDF's both
  along z) or a sphere; a collision mesh by its convex hull (what MuJoCo collides a mesh by);
- a link with no collision shape gets one primitive fitted to its visual geometry's bounds
  in the link frame: a capsule along the longest side when that side is at least
  `CAPSULE_ASPECT` times the next (through the bounds' centre, as long as they are, its
  diameter their next side), else the bounding box;
- a link with neither has nothing to collide with.

The geoms collide with the floor only (contype 0, conaffinity 1, as the soles: no
self-collision) and carry no mass (the inertias are pinocchio's, `mjcf`).
"""

from __future__ import annotations

from xml.sax.saxutils import quoteattr

import numpy as np
import pinocchio as pin

from app.core.quaternions import matrix_to_wxyz
from app.core.robot.meshes import LinkMesh
from app.core.robot.model import RobotModel
from app.core.robot.triangles import TriangleMesh
from app.core.robot.urdf_xml import Geometry

CAPSULE_ASPECT = 2.0
"""A fitted link is a capsule when its longest side is this many times the next, else a box."""
MIN_SIDE_M = 1e-4
"""Sides thinner than this are given this (MuJoCo refuses zero sizes)."""
FLOOR_ONLY = 'contype="0" conaffinity="1" condim="3" group="3" mass="0"'
"""A geom the floor (contype 1) collides with, and nothing else."""


def _f(values) -> str:
    return " ".join(repr(float(x)) for x in np.ravel(values))


def _pose(T: np.ndarray) -> str:
    return f'pos="{_f(T[:3, 3])}" quat="{_f(matrix_to_wxyz(T[:3, :3]))}"'


def link_geoms(robot: RobotModel, jid: int, body: str) -> tuple[list[str], list[str]]:
    """(mesh assets, geoms) for the links carried by pinocchio joint `jid` (the MuJoCo body
    `body`), in that joint's frame (module docstring)."""
    model = robot.model
    assets: list[str] = []
    geoms: list[str] = []
    for frame in model.frames:
        if frame.parentJoint != jid or frame.type != pin.BODY:
            continue
        T_joint_link = frame.placement.homogeneous
        shapes = [
            g for g in robot.tree.geometries if g.link == frame.name and g.role == "collision"
        ]
        made = []
        for shape in shapes:
            made += _collision(robot, shape, T_joint_link, f"{body}_{len(assets)}", assets)
        if not made:
            visual = [m for m in robot.meshes if m.link == frame.name and m.role == "visual"]
            made = _fitted(visual, T_joint_link)
        geoms += made
    return assets, geoms


def _collision(
    robot: RobotModel, shape: Geometry, T_joint_link: np.ndarray, key: str, assets: list[str]
) -> list[str]:
    """The geom of one URDF collision shape ([] for a mesh that did not load)."""
    T = T_joint_link @ shape.T_link_geom
    size = np.maximum(np.asarray(shape.size, dtype=float), MIN_SIDE_M)
    if shape.kind == "box":
        return [f'<geom type="box" size="{_f(0.5 * size)}" {_pose(T)} {FLOOR_ONLY}/>']
    if shape.kind == "cylinder":
        return [
            f'<geom type="cylinder" size="{_f([size[0], 0.5 * size[1]])}" {_pose(T)} {FLOOR_ONLY}/>'
        ]
    if shape.kind == "sphere":
        return [f'<geom type="sphere" size="{_f(size[:1])}" {_pose(T)} {FLOOR_ONLY}/>']
    loaded = _loaded_mesh(robot.meshes, shape)
    if loaded is None:
        return []
    hull = convex_hull(loaded.vertices)
    if hull is None:  # a flat mesh has no hull: the fitted primitive instead
        return _fitted(
            [LinkMesh(shape.link, "collision", shape.T_link_geom, loaded, None)], T_joint_link
        )
    name = f"link_hull_{key}_{len(assets)}"
    assets.append(
        f"<mesh name={quoteattr(name)} vertex={quoteattr(_f(hull.vertices))} "
        f"face={quoteattr(' '.join(str(int(i)) for i in np.ravel(hull.faces)))}/>"
    )
    return [f'<geom type="mesh" mesh={quoteattr(name)} {_pose(T)} {FLOOR_ONLY}/>']


def convex_hull(points: np.ndarray) -> TriangleMesh | None:
    """The convex hull of `points` [m], shape (N, 3); None for a flat set, which has none.
    trimesh and scipy's Qhull are imported here: only a model with hulls pays for them."""
    import trimesh
    from scipy.spatial import QhullError

    try:
        hull = trimesh.convex.convex_hull(points)
    except (QhullError, ValueError):
        return None
    return TriangleMesh(np.asarray(hull.vertices, dtype=float), np.asarray(hull.faces))


def _loaded_mesh(meshes: tuple[LinkMesh, ...], shape: Geometry) -> TriangleMesh | None:
    """The mesh loaded for a URDF mesh shape (same link, role and placement), None if it did
    not load."""
    for mesh in meshes:
        if (
            mesh.link == shape.link
            and mesh.role == shape.role
            and np.allclose(mesh.T_link_mesh, shape.T_link_geom)
            and len(mesh.mesh.vertices) >= 4
        ):
            return mesh.mesh
    return None


def _fitted(meshes: list[LinkMesh], T_joint_link: np.ndarray) -> list[str]:
    """One box or capsule fitted to the meshes' bounds in the link frame (module docstring;
    [] without vertices)."""
    points = [
        m.T_link_mesh[:3, :3] @ np.asarray(m.mesh.vertices, dtype=float).T + m.T_link_mesh[:3, 3:4]
        for m in meshes
        if len(m.mesh.vertices)
    ]
    if not points:
        return []
    stacked = np.concatenate(points, axis=1)
    low, high = stacked.min(axis=1), stacked.max(axis=1)
    centre, sides = 0.5 * (low + high), np.maximum(high - low, MIN_SIDE_M)
    T = T_joint_link.copy()
    T[:3, 3] = T_joint_link[:3, :3] @ centre + T_joint_link[:3, 3]
    order = np.argsort(sides)[::-1]
    if sides[order[0]] < CAPSULE_ASPECT * sides[order[1]]:
        return [f'<geom type="box" size="{_f(0.5 * sides)}" {_pose(T)} {FLOOR_ONLY}/>']
    # the capsule along the longest side, as long as the bounds, as thick as the next side
    radius = 0.5 * float(sides[order[1]])
    half = max(0.5 * float(sides[order[0]]) - radius, MIN_SIDE_M)
    a, b = (T[:3, :3] @ np.eye(3)[order[0]]) * half, T[:3, 3]
    return [
        f'<geom type="capsule" size="{_f(radius)}" fromto="{_f(b - a)} {_f(b + a)}" {FLOOR_ONLY}/>'
    ]
