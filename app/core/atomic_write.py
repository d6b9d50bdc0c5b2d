"""Write an output file whole or not at all: temporary file in the same folder, fsync, rename.

A failure at any point (disk full, a read-only folder, a file-size limit, an error in the
writer itself) removes the temporary file and leaves whatever was at the target untouched:
never a file cut mid-row. An existing target that is not a regular file (`/dev/full`, a pipe,
a folder) is refused before anything is written, so a rename never replaces a device.
"""

from __future__ import annotations

import contextlib
import os
import stat
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import IO

from app.core.errors import StudioError


class OutputError(StudioError):
    """An output file that could not be written; nothing was changed at its path."""


def write_atomically(
    path: str | os.PathLike[str],
    write: Callable[[IO[str]], object],
    error: type[StudioError] = OutputError,
) -> None:
    """Call write(file) on a temporary text file beside `path`, then move it into place.

    The text is UTF-8 with newline="" (csv writers choose their own line ends); the data is
    fsync-ed before the rename, which is atomic within one folder (POSIX rename(2))."""
    _replace(path, lambda fd: os.fdopen(fd, "w", encoding="utf-8", newline=""), write, error)


def write_bytes_atomically(
    path: str | os.PathLike[str], data: bytes, error: type[StudioError] = OutputError
) -> None:
    """Write `data` to `path` whole or not at all (temporary file, fsync, rename), with the
    checks of `write_atomically`: the binary counterpart, for archives."""
    write_binary_atomically(path, lambda file: file.write(data), error)


def write_binary_atomically(
    path: str | os.PathLike[str],
    write: Callable[[IO[bytes]], object],
    error: type[StudioError] = OutputError,
) -> None:
    """Call write(file) on a temporary binary file beside `path` (seekable), then move it into
    place, as `write_atomically` does: for archives written entry by entry, never whole in
    memory."""
    _replace(path, lambda fd: os.fdopen(fd, "w+b"), write, error)


def _replace(
    path: str | os.PathLike[str],
    open_fd: Callable[[int], IO],
    write: Callable[[IO], object],
    error: type[StudioError],
) -> None:
    """Refuse a target that is not a regular file; `write` a temporary file beside it (opened
    by `open_fd` from its descriptor); fsync; keep the target's mode (else the umask's);
    rename into place."""
    target = Path(os.fspath(path))
    try:
        info = os.stat(target)
    except FileNotFoundError:
        info = None
    except OSError as exc:
        raise error(f"cannot write {target}: {exc.strerror or exc}") from None
    if info is not None and not stat.S_ISREG(info.st_mode):
        raise error(f"cannot write {target}: it exists and is not a regular file")
    folder = target.parent if str(target.parent) else Path(".")
    try:
        fd, temp_name = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=folder)
    except OSError as exc:
        raise error(f"cannot write {target}: {exc.strerror or exc}") from None
    try:
        with open_fd(fd) as file:
            write(file)
            file.flush()
            os.fsync(file.fileno())
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(temp_name, stat.S_IMODE(info.st_mode) if info is not None else 0o666 & ~umask)
        os.replace(temp_name, target)
    except OSError as exc:
        _remove(temp_name)
        raise error(f"cannot write {target}: {exc.strerror or exc}; nothing was written") from None
    except BaseException:
        _remove(temp_name)
        raise


def _remove(name: str) -> None:
    with contextlib.suppress(OSError):
        os.unlink(name)
