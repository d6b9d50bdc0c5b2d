"""A project's robot: which built-in it is, or its URDF and meshes packed to travel.

An embedded robot is packed as an upload archive (app.core.robot.uploads) and unpacked on
open by the same code as any upload, with all its checks (zip slip, zip bombs, links, sizes):
a project from elsewhere is exactly as trusted as an uploaded robot.

Layout: a robot that came from an upload is packed whole (its folder is its sandbox). Any
other URDF goes to `robot/NAME.urdf`, a mesh at a relative path beside it to the same path
under `robot/`, and a `package://PKG/rest` mesh to `PKG/rest`, where the upload's package
look-up finds it again. A mesh anywhere else (an absolute path, `../`) is not embedded; the
project says so in `RobotSource.notes` and the reopened robot lists it as missing.
"""

from __future__ import annotations

import io
import os
import zipfile
from pathlib import Path, PurePosixPath

from app.core import input_gate
from app.core.errors import StudioError
from app.core.file_access import FileAccess
from app.core.projects.codec import ProjectError
from app.core.projects.project import RobotSource
from app.core.robot.loading import load_robot
from app.core.robot.model import RobotModel
from app.core.robot.packages import PackageResolver
from app.core.robot.uploads import UPLOAD_MARKER, store_upload, upload_sandbox_of
from robots.catalogue import BUILTIN_ROBOTS


def robot_source(robot: RobotModel, package_roots: tuple[Path, ...] = ()) -> RobotSource:
    """How to find `robot` again: its built-in name, or its files packed."""
    feet = (robot.feet[0].link, robot.feet[1].link)
    source = Path(os.path.realpath(robot.source))
    for name, builtin in BUILTIN_ROBOTS.items():
        if source == Path(os.path.realpath(builtin.urdf_path)):
            return RobotSource(name=robot.name, builtin=name, feet=feet)
    sandbox = upload_sandbox_of(source)
    notes: tuple[str, ...] = ()
    if sandbox is not None:
        files, entry = _pack_folder(sandbox, source), source.relative_to(sandbox)
    else:
        files, entry, notes = _pack_urdf(robot, source, package_roots)
    return RobotSource(
        name=robot.name,
        files=files,
        urdf_entry=PurePosixPath(*entry.parts).as_posix(),
        feet=feet,
        notes=notes,
    )


def _pack_folder(folder: Path, urdf: Path) -> bytes:
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as archive:
        for path in sorted(folder.rglob("*")):
            if path.is_file() and not path.is_symlink() and path.name != UPLOAD_MARKER:
                archive.writestr(path.relative_to(folder).as_posix(), _read(path, urdf))
    return buffer.getvalue()


def _read(path: Path, urdf: Path) -> bytes:
    kind = input_gate.URDF if path == urdf else input_gate.MESH
    return input_gate.read_bytes(path, kind, ProjectError)


def _pack_urdf(
    robot: RobotModel, urdf: Path, package_roots: tuple[Path, ...]
) -> tuple[bytes, Path, tuple[str, ...]]:
    entry = Path("robot") / urdf.name
    files: dict[str, bytes] = {entry.as_posix(): _read(urdf, urdf)}
    notes: list[str] = []
    resolver = PackageResolver(urdf.parent, package_roots)
    for uri in sorted({g.uri for g in robot.tree.geometries if g.kind == "mesh" and g.uri}):
        resolution = resolver.resolve(uri)
        target = _entry_for(uri)
        if resolution.path is None:
            notes.append(f"mesh {uri} was not found when saving; not embedded")
        elif target is None:
            notes.append(f"mesh {uri} lies outside the robot's folders; not embedded")
        elif target not in files:
            files[target] = _read(resolution.path, urdf)
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as archive:
        for name, data in files.items():
            archive.writestr(name, data)
    return buffer.getvalue(), entry, tuple(notes)


def _entry_for(uri: str) -> str | None:
    """Where a mesh URI's file goes in the packed archive, None if it cannot travel."""
    if uri.startswith("package://"):
        relative = PurePosixPath(uri[len("package://") :])
    elif uri.startswith("file://") or PurePosixPath(uri).is_absolute():
        return None
    else:
        relative = PurePosixPath("robot") / uri
    if ".." in relative.parts or not relative.parts:
        return None
    return relative.as_posix()


def load_project_robot(
    source: RobotSource,
    uploads_root: Path,
    package_roots: tuple[Path, ...] = (),
    access: FileAccess | None = None,
) -> RobotModel:
    """Load the robot of a project: a built-in, or its files unpacked as an upload."""
    feet = source.feet if all(source.feet) else None
    try:
        if source.builtin:
            if source.builtin not in BUILTIN_ROBOTS:
                names = ", ".join(BUILTIN_ROBOTS)
                raise ProjectError(
                    f"the project's robot {source.builtin!r} is not a built-in robot ({names})"
                )
            return load_robot(source.builtin, package_roots=package_roots, feet=feet)
        if not source.files:
            raise ProjectError("the project holds neither a built-in robot name nor its files")
        urdf = store_upload(f"{source.name or 'robot'}.zip", source.files, uploads_root)
        sandbox = upload_sandbox_of(urdf)
        entry = PurePosixPath(source.urdf_entry)
        if sandbox is None or entry.is_absolute() or ".." in entry.parts or not entry.parts:
            raise ProjectError(
                f"robot.urdf_entry {source.urdf_entry!r} is not inside the robot's files"
            )
        path = sandbox.joinpath(*entry.parts)
        if not path.is_file():
            raise ProjectError(
                f"robot.urdf_entry {source.urdf_entry!r} is not in the robot's files"
            )
        return load_robot(path, feet=feet, sandbox=sandbox, access=access)
    except ProjectError:
        raise
    except StudioError as error:
        raise ProjectError(f"the project's robot {source.name!r} does not load: {error}") from None
