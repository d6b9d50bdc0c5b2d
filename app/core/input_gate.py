"""One gate for every file the studio or the CLI reads: regular files only, sizes checked first.

Every reader (URDF, meshes, motion / torque / measurement CSVs, TOML, uploads) asks this
module for the bytes or text of a file. Before a single byte is read, the path is `os.stat`-ed
and refused unless it is a regular file (a FIFO would block forever, `/dev/zero` never ends, a
directory is not a file) no larger than its kind's limit. The file is then opened with
O_NONBLOCK (so even a FIFO swapped in after the check cannot block), checked again with fstat,
and read up to the limit only.

Limits, one per kind of file (docs/safety.md lists them):

    URDF                      20 MiB
    mesh (STL, DAE, PLY, GLB, OFF)  64 MiB; binary STL ≤ 1 000 000 triangles (header checked
                              against the file size); OBJ and DAE 16 MiB (text: ~25× its size
                              in memory)
    compressed meshes (.gz .bz2 .xz .zip .zst .7z .tar.*): refused, unpack them first
    motion CSV                256 MiB, streamed (100 000 samples of a 30-joint robot)
    torque CSV                128 MiB, streamed
    measurement CSV           16 MiB
    TOML (plan.toml, k.toml)  1 MiB, nesting ≤ 16 levels, integers within ±2⁶³, finite floats
    upload (.urdf or .zip)    100 MiB (see app.core.robot.uploads for the archive limits)

Text must be UTF-8 (a byte-order mark is accepted); anything else is refused with the byte
offset of the first bad byte.
"""

from __future__ import annotations

import dataclasses
import io
import math
import os
import stat
from typing import Any

from app.core.errors import StudioError

MiB = 2**20


class InputRefused(StudioError):
    """A file the gate will not read: not a regular file, too large, not UTF-8, malformed."""


@dataclasses.dataclass(frozen=True)
class FileKind:
    """A kind of input file and its size limit."""

    name: str
    max_bytes: int


URDF = FileKind("URDF", 20 * MiB)
MESH = FileKind("mesh", 64 * MiB)
TEXT_MESH = FileKind("OBJ or DAE mesh", 16 * MiB)
MOTION_CSV = FileKind("motion CSV", 256 * MiB)
TORQUE_CSV = FileKind("torque CSV", 128 * MiB)
MEASURED_CSV = FileKind("measurement CSV", 16 * MiB)
TOML = FileKind("TOML", 1 * MiB)
UPLOAD = FileKind("upload", 100 * MiB)
KINDS = (URDF, MESH, TEXT_MESH, MOTION_CSV, TORQUE_CSV, MEASURED_CSV, TOML, UPLOAD)

TOML_MAX_DEPTH = 16
"""Deepest nesting of tables and arrays accepted in a TOML file (`a = [[1]]` is 2 deep)."""
TOML_MAX_INT = 2**63
"""Integers in TOML must lie strictly within ±TOML_MAX_INT."""


def _what_it_is(mode: int) -> str:
    if stat.S_ISDIR(mode):
        return "a folder"
    if stat.S_ISFIFO(mode):
        return "a pipe (FIFO)"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def _size_text(size: int) -> str:
    return f"{size / MiB:.1f} MiB" if size >= MiB else f"{size} bytes"


def check_file(
    path: str | os.PathLike[str], kind: FileKind, error: type[StudioError] = InputRefused
) -> os.stat_result:
    """stat(path) if it is a regular file within the kind's size limit; `error` otherwise."""
    name = os.fspath(path)
    try:
        info = os.stat(name)
    except OSError as exc:
        raise error(f"cannot read {name}: {exc.strerror or exc}") from None
    _check_stat(info, name, kind, error)
    return info


def _check_stat(info: os.stat_result, name: str, kind: FileKind, error: type[StudioError]) -> None:
    if not stat.S_ISREG(info.st_mode):
        raise error(f"{name} is {_what_it_is(info.st_mode)}; give a {kind.name} file")
    if info.st_size > kind.max_bytes:
        raise error(
            f"{name} is {_size_text(info.st_size)}; a {kind.name} file over "
            f"{_size_text(kind.max_bytes)} is refused"
        )


def _open_checked(name: str, kind: FileKind, error: type[StudioError]) -> int:
    """A file descriptor of a regular file within the kind's limit (checked before and after
    opening; O_NONBLOCK so that not even a FIFO swapped in between can block)."""
    check_file(name, kind, error)
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0)
    try:
        fd = os.open(name, flags | getattr(os, "O_CLOEXEC", 0))
    except OSError as exc:
        raise error(f"cannot read {name}: {exc.strerror or exc}") from None
    try:
        _check_stat(os.fstat(fd), name, kind, error)  # the file may have been swapped
    except BaseException:
        os.close(fd)
        raise
    return fd


def open_binary(
    path: str | os.PathLike[str], kind: FileKind, error: type[StudioError] = InputRefused
) -> io.BufferedReader:
    """The file as a binary stream, after the checks of `check_file`: for readers that take
    only the parts they need (a zip's directory and entries) instead of the whole file."""
    fd = _open_checked(os.fspath(path), kind, error)
    return io.BufferedReader(io.FileIO(fd, "r"))


def open_text(
    path: str | os.PathLike[str], kind: FileKind, error: type[StudioError] = InputRefused
) -> io.TextIOWrapper:
    """The file as a UTF-8 text stream (BOM dropped, newline="" for csv), after the checks of
    `check_file`: for readers that parse as they go. Decoding errors surface as
    UnicodeDecodeError while reading; the caller turns them into its own error."""
    fd = _open_checked(os.fspath(path), kind, error)
    return io.TextIOWrapper(io.FileIO(fd, "r"), encoding="utf-8-sig", newline="")


def read_bytes(
    path: str | os.PathLike[str], kind: FileKind, error: type[StudioError] = InputRefused
) -> bytes:
    """The whole file, after the checks of `check_file`, never more than kind.max_bytes."""
    name = os.fspath(path)
    fd = _open_checked(name, kind, error)
    try:
        chunks: list[bytes] = []
        total = 0
        while True:
            chunk = os.read(fd, min(1 << 20, kind.max_bytes + 1 - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
            if total > kind.max_bytes:
                raise error(
                    f"{name} grew past {_size_text(kind.max_bytes)} while being read; refused"
                )
    except OSError as exc:
        raise error(f"{name}: cannot read: {exc.strerror or exc}") from None
    finally:
        os.close(fd)
    return b"".join(chunks)


def decode_text(data: bytes, name: str, error: type[StudioError] = InputRefused) -> str:
    """UTF-8 text (a leading byte-order mark is dropped), or `error` naming the first bad byte."""
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise error(
            f"{name}: not UTF-8 text (byte {exc.start} is 0x{data[exc.start]:02x}); "
            "save the file as UTF-8"
        ) from None


def read_text(
    path: str | os.PathLike[str], kind: FileKind, error: type[StudioError] = InputRefused
) -> str:
    """The file as UTF-8 text, after the checks of `read_bytes`."""
    return decode_text(read_bytes(path, kind, error), os.fspath(path), error)


def read_toml(
    path: str | os.PathLike[str], error: type[StudioError] = InputRefused
) -> dict[str, Any]:
    """A TOML file (≤ 1 MiB, UTF-8) parsed and checked by `parse_toml`."""
    return parse_toml(read_text(path, TOML, error), os.fspath(path), error)


def parse_toml(text: str, name: str, error: type[StudioError] = InputRefused) -> dict[str, Any]:
    """TOML text as a dict: nesting ≤ TOML_MAX_DEPTH, |integers| < 2⁶³, floats finite."""
    import tomllib

    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{name}: not valid TOML: {exc}") from None
    except RecursionError:
        raise error(
            f"{name}: nested too deeply to parse; at most {TOML_MAX_DEPTH} levels are accepted"
        ) from None
    except ValueError as exc:  # e.g. an integer of more than 4300 digits
        raise error(f"{name}: a value cannot be read ({exc}); use ordinary numbers") from None
    _check_toml_values(data, name, error)
    return data


def _check_toml_values(data: dict[str, Any], name: str, error: type[StudioError]) -> None:
    # depth: how many tables / arrays a container is inside of, the document itself at 0
    stack: list[tuple[str, Any, int]] = [("", data, 0)]
    while stack:
        key, value, depth = stack.pop()
        if isinstance(value, dict | list) and depth > TOML_MAX_DEPTH:
            raise error(
                f"{name}: {key or 'a value'} is nested {depth} levels deep; "
                f"at most {TOML_MAX_DEPTH} are accepted"
            )
        if isinstance(value, dict):
            stack.extend((f"{key}.{k}" if key else str(k), v, depth + 1) for k, v in value.items())
        elif isinstance(value, list):
            stack.extend((f"{key}[{i}]", v, depth + 1) for i, v in enumerate(value))
        elif isinstance(value, bool):
            continue
        elif isinstance(value, int) and not -TOML_MAX_INT < value < TOML_MAX_INT:
            raise error(f"{name}: {key} is an integer of {len(str(abs(value)))} digits; too large")
        elif isinstance(value, float) and not math.isfinite(value):
            raise error(f"{name}: {key} is {value}; give a finite number")
