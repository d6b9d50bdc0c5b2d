"""The autosave folder: the last few saves of the studio's work, newest last.

Each autosave is a whole project file named by its UTC time (`autosave-20261123T112233-123456Z
.bstudio`, so names sort by age), written atomically (temporary file, fsync, rename). Older
files beyond `keep` are removed only after a new one is complete: a write that fails (disk
full, read-only folder) leaves every earlier autosave as it was.
"""

from __future__ import annotations

import contextlib
import re
from collections.abc import Callable
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import IO

from app.core.atomic_write import write_binary_atomically, write_bytes_atomically
from app.core.projects.codec import ProjectError
from app.core.projects.files import SUFFIX

KEEP = 5
_NAME = re.compile(r"autosave-\d{8}T\d{6}-\d{6}Z\.bstudio")


class AutosaveStore:
    """The autosaves in one folder."""

    def __init__(self, folder: Path, keep: int = KEEP) -> None:
        self.folder = folder
        self.keep = keep

    def saves(self) -> list[Path]:
        """The autosaves, oldest first."""
        if not self.folder.is_dir():
            return []
        return sorted(p for p in self.folder.iterdir() if _NAME.fullmatch(p.name) and p.is_file())

    def latest(self) -> Path | None:
        saves = self.saves()
        return saves[-1] if saves else None

    def write(
        self, data: bytes | Callable[[IO[bytes]], object], now: datetime | None = None
    ) -> Path:
        """Store one autosave, its bytes or what `data(file)` writes to the file;
        ProjectError (and nothing removed) if it cannot be written."""
        stamp = (now or datetime.now(UTC)).strftime("%Y%m%dT%H%M%S-%fZ")
        path = self.folder / f"autosave-{stamp}{SUFFIX}"
        existing = self.saves()
        if existing and path.name <= existing[-1].name:  # same microsecond, or a clock step back
            path = self.folder / _after(existing[-1].name)
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise ProjectError(f"cannot create {self.folder}: {exc.strerror or exc}") from None
        if isinstance(data, bytes):
            write_bytes_atomically(path, data, ProjectError)
        else:
            write_binary_atomically(path, data, ProjectError)
        for old in self.saves()[: -self.keep]:
            with contextlib.suppress(OSError):
                old.unlink()
        return path


def _after(name: str) -> str:
    """A name sorting just after `name` (its microseconds plus one)."""
    stem = name[len("autosave-") : -len("Z.bstudio")]
    moment = datetime.strptime(stem, "%Y%m%dT%H%M%S-%f")
    return f"autosave-{(moment + timedelta(microseconds=1)).strftime('%Y%m%dT%H%M%S-%f')}Z{SUFFIX}"
