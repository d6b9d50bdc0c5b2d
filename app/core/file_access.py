"""Which folders a path typed into the studio may lead to: the allowed-folders policy.

The studio serves a browser; whoever drives that browser may type any path into *Open path*.
`FileAccess` holds the folders such paths may resolve into: the working folder, the folders
given with `--allow DIR`, the built-in robots and the upload store. A path is resolved with
symbolic links followed (`os.path.realpath`) before it is compared, so a link inside an
allowed folder pointing outside is refused too.

A refused path gets the same message whether it exists or not, is a file or a folder: the
message repeats the text typed, never anything learned from the file system.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

from app.core.errors import StudioError


class PathNotAllowed(StudioError):
    """A path outside the folders the studio may open."""


@dataclasses.dataclass(frozen=True)
class FileAccess:
    """The folders (resolved, absolute) a user-typed path may lead into."""

    roots: tuple[Path, ...]

    @classmethod
    def for_studio(
        cls,
        working_dir: str | os.PathLike[str] = ".",
        allow: tuple[str | os.PathLike[str], ...] = (),
        uploads_root: str | os.PathLike[str] | None = None,
    ) -> FileAccess:
        """The working folder, `--allow` folders, the built-in robots and the upload store."""
        from robots.catalogue import ROBOTS_DIR

        folders = [working_dir, *allow, ROBOTS_DIR]
        if uploads_root is not None:
            folders.append(uploads_root)
        return cls(tuple(Path(os.path.realpath(folder)) for folder in folders))

    def allows(self, path: str | os.PathLike[str]) -> bool:
        """Whether `path`, symbolic links followed, lies inside one of the roots."""
        if "\0" in os.fspath(path):  # no file has such a name (os calls raise ValueError)
            return False
        resolved = Path(os.path.realpath(os.fspath(path)))
        return any(resolved == root or resolved.is_relative_to(root) for root in self.roots)

    def check(self, path: str | os.PathLike[str]) -> Path:
        """The resolved path if allowed; PathNotAllowed otherwise (revealing nothing about it)."""
        if "\0" in os.fspath(path):
            raise PathNotAllowed("a path cannot hold a NUL character; type the path again")
        if not self.allows(path):
            raise PathNotAllowed(
                f"{os.fspath(path)}: not inside the folders the studio may open; start it with "
                "--allow FOLDER to open files there, or upload the robot"
            )
        return Path(os.path.realpath(os.fspath(path)))

    def describe(self) -> list[str]:
        """The allowed folders, for the studio's help text."""
        return [str(root) for root in self.roots]
