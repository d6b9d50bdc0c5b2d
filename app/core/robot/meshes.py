"""Geometry of a robot's links as triangle meshes, with missing files reported.

Primitive shapes are tessellated (app.core.robot.triangles, numpy only); mesh files (STL, DAE,
OBJ, …) pass the mesh gate (app.core.robot.mesh_gate: format, size, triangle count) and are
then loaded through trimesh, imported only then, scaled as the URDF says, and cached by path
and scale within one load.
"""

from __future__ import annotations

import dataclasses
import io
from collections.abc import Callable
from pathlib import Path

import numpy as np

from app.core.errors import StudioError
from app.core.robot.mesh_gate import (
    MAX_MESH_TRIANGLES,
    MAX_ROBOT_MESH_BYTES,
    MAX_ROBOT_TRIANGLES,
    read_mesh_file,
)
from app.core.robot.packages import PackageResolver
from app.core.robot.triangles import TriangleMesh, box, cylinder, icosphere
from app.core.robot.urdf_xml import Geometry


@dataclasses.dataclass(frozen=True)
class LinkMesh:
    """A mesh to draw rigidly attached to a link."""

    link: str
    role: str
    """"visual" or "collision"."""
    T_link_mesh: np.ndarray
    """Placement of the mesh in its link's frame, 4x4."""
    mesh: TriangleMesh
    rgba: tuple[float, float, float, float] | None


@dataclasses.dataclass(frozen=True)
class MissingMesh:
    link: str
    role: str
    uri: str
    reason: str


def load_link_meshes(
    geometries: tuple[Geometry, ...],
    resolver: PackageResolver,
    progress: Callable[[int, int], None] | None = None,
) -> tuple[list[LinkMesh], list[MissingMesh]]:
    """Meshes of all visual and collision geometry; unreadable files are listed, not raised.
    `progress(done, total)` is told before each mesh file geometry is read (1-based)."""
    meshes: list[LinkMesh] = []
    missing: list[MissingMesh] = []
    cache: dict[tuple[Path, tuple[float, ...]], TriangleMesh | str] = {}
    budget = _Budget()
    total = sum(geom.kind == "mesh" for geom in geometries)
    done = 0
    for geom in geometries:
        if geom.kind != "mesh":
            meshes.append(
                LinkMesh(geom.link, geom.role, geom.T_link_geom, primitive_mesh(geom), geom.rgba)
            )
            continue
        done += 1
        if progress is not None:
            progress(done, total)
        resolution = resolver.resolve(geom.uri)
        if resolution.path is None:
            missing.append(MissingMesh(geom.link, geom.role, geom.uri, resolution.reason))
            continue
        key = (resolution.path, geom.size)
        if key not in cache:
            cache[key] = budget.load(resolution.path, np.array(geom.size))
        loaded = cache[key]
        if isinstance(loaded, str):
            missing.append(MissingMesh(geom.link, geom.role, geom.uri, loaded))
        else:
            meshes.append(LinkMesh(geom.link, geom.role, geom.T_link_geom, loaded, geom.rgba))
    return meshes, missing


class _Budget:
    """Mesh bytes read and triangles kept for one robot, against the robot-wide limits."""

    def __init__(self) -> None:
        self.bytes_read = 0
        self.triangles = 0

    def load(self, path: Path, scale: np.ndarray) -> TriangleMesh | str:
        try:
            size = path.stat().st_size
        except OSError as exc:
            return f"cannot read mesh {path.name}: {exc.strerror}"
        if self.bytes_read + size > MAX_ROBOT_MESH_BYTES:
            return (
                f"mesh {path.name} skipped: the robot's meshes exceed "
                f"{MAX_ROBOT_MESH_BYTES // 2**20} MiB in all"
            )
        self.bytes_read += size
        loaded = _load_file(path, scale)
        if isinstance(loaded, str):
            return loaded
        if self.triangles + len(loaded.faces) > MAX_ROBOT_TRIANGLES:
            return (
                f"mesh {path.name} skipped: the robot's meshes exceed {MAX_ROBOT_TRIANGLES} "
                "triangles in all"
            )
        self.triangles += len(loaded.faces)
        return loaded


def primitive_mesh(geom: Geometry) -> TriangleMesh:
    if geom.kind == "box":
        return box(geom.size)
    if geom.kind == "cylinder":
        return cylinder(geom.size[0], geom.size[1])
    return icosphere(geom.size[0])


def _load_file(path: Path, scale: np.ndarray) -> TriangleMesh | str:
    """The mesh in the file, scaled; or a one-line reason it cannot be used."""
    try:
        data, file_type = read_mesh_file(path)
    except StudioError as exc:
        return str(exc)
    import trimesh  # about a CPU-second with scipy: only a robot with mesh files pays it

    try:
        loaded = trimesh.load(io.BytesIO(data), file_type=file_type, force="mesh", process=False)
    except (
        Exception
    ) as exc:  # trimesh raises many types for corrupt files; report which file failed.
        return f"cannot read mesh {path.name}: {type(exc).__name__}: {exc}"
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        return f"mesh {path.name} holds no triangles"
    if len(loaded.faces) > MAX_MESH_TRIANGLES:
        return f"mesh {path.name} has {len(loaded.faces)} triangles, over the limit of {MAX_MESH_TRIANGLES}"
    vertices = np.array(loaded.vertices, dtype=float)
    faces = np.array(loaded.faces, dtype=np.int64)
    if not np.all(np.isfinite(vertices)):
        return f"mesh {path.name} has non-finite vertices"
    if not np.allclose(scale, 1.0):  # as trimesh's apply_transform: a mirror flips the winding
        vertices = vertices * scale
        if np.prod(scale) < 0:
            faces = np.ascontiguousarray(faces[:, ::-1])
    return TriangleMesh(vertices, faces)
