"""Resolve mesh paths written in URDFs: relative paths, file:// and package://NAME/… .

A `package://NAME/rest` path is looked for, in order, in: a folder NAME among the URDF's
ancestors and their children (the usual layout of a ROS description package or an unpacked
archive), the roots the user gives, ROS_PACKAGE_PATH, and installed share folders (ament /
cmeel prefixes, such as the `example-robot-data` wheel's). No environment variable is needed
for a robot whose package folder sits above or beside its URDF.

When a sandbox folder is given (uploaded robots), a path outside it is never returned.
"""

from __future__ import annotations

import dataclasses
import os
import sys
import sysconfig
from collections.abc import Callable
from pathlib import Path


@dataclasses.dataclass(frozen=True)
class Resolution:
    """Where a mesh URI points, or why it points nowhere."""

    uri: str
    path: Path | None
    reason: str = ""
    """Empty when found; otherwise what was searched, in words a user can act on."""


class PackageResolver:
    """Finds the files behind mesh URIs of one URDF."""

    def __init__(
        self,
        urdf_dir: Path,
        extra_roots: tuple[Path, ...] = (),
        sandbox: Path | None = None,
        allowed: Callable[[Path], bool] | None = None,
    ):
        self.urdf_dir = urdf_dir.resolve()
        self.extra_roots = tuple(Path(root).resolve() for root in extra_roots)
        self.sandbox = sandbox.resolve() if sandbox is not None else None
        self.allowed = allowed

    def resolve(self, uri: str) -> Resolution:
        if uri.startswith("package://"):
            package, _, rest = uri[len("package://") :].partition("/")
            if not package or not rest:
                return Resolution(
                    uri, None, "malformed package:// path, expected package://NAME/path"
                )
            for folder in self._package_folders(package):
                found = self._checked(folder / rest)
                if found is not None:
                    return Resolution(uri, found)
            return Resolution(
                uri,
                None,
                f"package {package!r} not found (looked above and beside the URDF, in the given "
                "package roots, ROS_PACKAGE_PATH and installed share folders); "
                "give its parent folder as a package root",
            )
        path = Path(uri[len("file://") :]) if uri.startswith("file://") else Path(uri)
        if not path.is_absolute():
            path = self.urdf_dir / path
        found = self._checked(path)
        if found is None:
            if self._outside_sandbox(path):
                return Resolution(uri, None, f"{uri}: outside the upload folder; refused")
            if self.allowed is not None and not self.allowed(path):
                return Resolution(uri, None, f"{uri}: outside the allowed folders; refused")
            return Resolution(uri, None, f"file not found: {path}")
        return Resolution(uri, found)

    def _package_folders(self, package: str):
        for ancestor in (self.urdf_dir, *self.urdf_dir.parents):
            if ancestor.name == package:
                yield ancestor
            yield ancestor / package
        if self.sandbox is not None:
            yield self.sandbox / package
            yield self.sandbox
        for root in self.extra_roots:
            yield root if root.name == package else root / package
        for entry in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep):
            if entry:
                root = Path(entry)
                yield root if root.name == package else root / package
        for prefix in _share_prefixes():
            yield prefix / "share" / package

    def _checked(self, path: Path) -> Path | None:
        try:
            resolved = path.resolve()
        except OSError:
            return None
        if self._outside_sandbox(resolved):
            return None
        if self.allowed is not None and not self.allowed(resolved):
            return None
        if not resolved.is_file():
            return None
        return resolved

    def _outside_sandbox(self, path: Path) -> bool:
        return self.sandbox is not None and not path.resolve().is_relative_to(self.sandbox)


def _share_prefixes() -> list[Path]:
    prefixes = [Path(sys.prefix), Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix"]
    for entry in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep):
        if entry:
            prefixes.append(Path(entry))
    return prefixes
