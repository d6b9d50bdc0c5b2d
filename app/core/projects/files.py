"""The .bstudio file: a zip holding `manifest.json` (format name, version, the project as
typed JSON) and one entry per array (`.npy`, allow_pickle=False) or byte string (the robot's
files, `.bin`).

Reading is as wary as an upload: the file passes the input gate (regular file, ≤ 256 MiB);
the zip's directory is checked whole before anything is read (at most MAX_ENTRIES entries, each
named like an entry this module writes, so no path can point anywhere; no encryption; known
compression; ≤ MAX_UNPACKED_BYTES unpacked); the manifest must be JSON without NaN, of this
format, of a version this studio reads; then every value is decoded by its declared type
(app.core.projects.codec) and every entry read is checked against the size its header states.
Writing streams the archive entry by entry into a temporary file beside the target and then
replaces the target atomically (fsync, rename), so an interrupted save leaves the previous file
as it was. Reading a file takes only the parts it needs from it (the directory, the manifest,
each entry), and each array goes straight from its entry into its own memory: a project's
arrays are held once, never as bytes and again as arrays.
"""

from __future__ import annotations

import io
import json
import os
import re
import zipfile
import zlib
from datetime import UTC, datetime
from typing import IO, Any

import numpy as np

from app.core import input_gate
from app.core.atomic_write import write_binary_atomically
from app.core.projects.codec import (
    Blob,
    JsonConstant,
    ProjectError,
    Reader,
    encode,
    read_npy_stream,
)
from app.core.projects.project import Project
from app.core.robot.uploads import SUPPORTED_COMPRESSION

FORMAT = "biped-studio-project"
VERSION = 1
"""Bump when a stored field changes meaning; older versions stay readable."""
SUFFIX = ".bstudio"
PROJECT_FILE = input_gate.FileKind("project (.bstudio)", 256 * input_gate.MiB)
MAX_ENTRIES = 2000
MAX_UNPACKED_BYTES = 1024 * input_gate.MiB
MAX_MANIFEST_BYTES = 16 * input_gate.MiB
_ENTRY = re.compile(
    r"manifest\.json|arrays/[A-Za-z0-9_.\-\[\]]{1,200}\.npy|blobs/[A-Za-z0-9_.\-\[\]]{1,200}\.bin"
)
_ZIP_FAILURES = (zipfile.BadZipFile, zipfile.LargeZipFile, zlib.error, EOFError, NotImplementedError, RuntimeError, ValueError, OSError)  # fmt: skip


def project_bytes(project: Project) -> bytes:
    """The .bstudio archive of `project` (stamped with the time of the call)."""
    buffer = io.BytesIO()
    write_project(buffer, project)
    return buffer.getvalue()


def write_project(file: IO[bytes], project: Project) -> None:
    """Write the .bstudio archive of `project` (stamped with the time of the call) to a
    seekable binary `file`, entry by entry: each array goes out in numpy's chunks, so no
    copy of it is made in memory."""
    stamped = Project(**{**_fields(project), "saved_at": datetime.now(UTC).isoformat()})
    blobs: dict[str, Blob] = {}
    manifest = {"format": FORMAT, "version": VERSION, "project": encode(stamped, "project", blobs)}
    with zipfile.ZipFile(file, "w") as archive:
        text = json.dumps(manifest, allow_nan=False, separators=(",", ":"))
        archive.writestr("manifest.json", text, zipfile.ZIP_DEFLATED)
        for name, blob in blobs.items():
            if isinstance(blob, bytes):
                archive.writestr(name, blob, zipfile.ZIP_STORED)
            else:
                with archive.open(name, "w", force_zip64=blob.nbytes > 1 << 30) as entry:
                    np.save(entry, np.ascontiguousarray(blob), allow_pickle=False)


def _fields(project: Project) -> dict[str, Any]:
    return {name: getattr(project, name) for name in project.__dataclass_fields__}


def save_project(path: str | os.PathLike[str], project: Project) -> None:
    """Write `project` to `path` atomically; ProjectError if it cannot be written."""
    write_binary_atomically(path, lambda file: write_project(file, project), ProjectError)


def read_project(path: str | os.PathLike[str]) -> Project:
    """The project in a .bstudio file, checked as described in the module docstring. The file
    is not read whole: its directory, manifest and entries are read from it as they are
    needed, each array straight into its own memory."""
    name = os.path.basename(os.fspath(path))
    with input_gate.open_binary(path, PROJECT_FILE, ProjectError) as file:
        return _parse(file, name)


def parse_project(data: bytes, name: str) -> Project:
    """The project in the bytes of a .bstudio archive (an upload, a file's content)."""
    if len(data) > PROJECT_FILE.max_bytes:
        raise ProjectError(
            f"{name} is over {PROJECT_FILE.max_bytes // input_gate.MiB} MiB; refused"
        )
    return _parse(io.BytesIO(data), name)


def _parse(file: IO[bytes], name: str) -> Project:
    try:
        archive = zipfile.ZipFile(file)
    except _ZIP_FAILURES as error:
        raise ProjectError(
            f"{name}: not a project file (not a valid zip archive: {error})"
        ) from None
    with archive:
        entries = _checked_entries(name, archive)
        if "manifest.json" not in entries:
            raise ProjectError(f"{name}: not a project file (no manifest.json inside)")

        def info_of(entry: str) -> zipfile.ZipInfo:
            if entry not in entries or entry == "manifest.json":
                raise ProjectError(
                    f"{name}: the manifest refers to {entry[:80]!r}, which is not in the file"
                )
            return entries[entry]

        def blob(entry: str) -> bytes:
            return _read_entry(name, archive, info_of(entry))

        def array(entry: str, where: str) -> np.ndarray:
            return _read_array(name, archive, info_of(entry), where)

        manifest = _manifest(
            name, blob_of=lambda: _read_entry(name, archive, entries["manifest.json"])
        )
        try:
            project = Reader(blob, array).decode(Project, manifest["project"], "project")
        except RecursionError:
            raise ProjectError(f"{name}: the manifest is nested too deeply") from None
    assert isinstance(project, Project)
    return project


def _checked_entries(name: str, archive: zipfile.ZipFile) -> dict[str, zipfile.ZipInfo]:
    infos = archive.infolist()
    if len(infos) > MAX_ENTRIES:
        raise ProjectError(
            f"{name}: {len(infos)} entries, over the limit of {MAX_ENTRIES}; refused"
        )
    if sum(info.file_size for info in infos) > MAX_UNPACKED_BYTES:
        raise ProjectError(
            f"{name}: unpacks to more than {MAX_UNPACKED_BYTES // input_gate.MiB} MiB; refused"
        )
    entries: dict[str, zipfile.ZipInfo] = {}
    for info in infos:
        if not _ENTRY.fullmatch(info.filename):
            raise ProjectError(
                f"{name}: entry {info.filename[:80]!r} is not one a project holds (a path outside "
                "the project or a foreign file); refused, nothing was opened"
            )
        if info.filename in entries:
            raise ProjectError(f"{name}: entry {info.filename!r} appears twice; refused")
        if info.flag_bits & 0x1:
            raise ProjectError(f"{name}: entry {info.filename!r} is encrypted; refused")
        if info.compress_type not in SUPPORTED_COMPRESSION:
            raise ProjectError(
                f"{name}: entry {info.filename!r} uses an unknown compression; refused"
            )
        entries[info.filename] = info
    return entries


def _read_entry(name: str, archive: zipfile.ZipFile, info: zipfile.ZipInfo) -> bytes:
    limit = MAX_MANIFEST_BYTES if info.filename == "manifest.json" else MAX_UNPACKED_BYTES
    if info.file_size > limit:
        raise ProjectError(f"{name}: entry {info.filename!r} is too large; refused")
    try:
        with archive.open(info) as source:
            data = source.read(info.file_size + 1)
    except _ZIP_FAILURES as error:
        raise ProjectError(f"{name}: damaged file ({info.filename}: {error})") from None
    if len(data) != info.file_size:
        raise ProjectError(
            f"{name}: entry {info.filename!r} does not hold the size its header says; refused"
        )
    return data


def _read_array(
    name: str, archive: zipfile.ZipFile, info: zipfile.ZipInfo, where: str
) -> np.ndarray:
    """The array of an `.npy` entry, streamed from the archive into its own memory after its
    header is checked against the entry's size (codec.read_npy_stream)."""
    if info.file_size > MAX_UNPACKED_BYTES:
        raise ProjectError(f"{name}: entry {info.filename!r} is too large; refused")
    try:
        with archive.open(info) as source:
            array = read_npy_stream(source, info.file_size, where)
            if source.read(1):
                raise ProjectError(
                    f"{name}: entry {info.filename!r} does not hold the size its header says; "
                    "refused"
                )
    except _ZIP_FAILURES as error:
        raise ProjectError(f"{name}: damaged file ({info.filename}: {error})") from None
    return array


def _manifest(name: str, blob_of) -> dict[str, Any]:
    text = input_gate.decode_text(blob_of(), f"{name}: manifest.json", ProjectError)
    try:
        manifest = json.loads(text, parse_constant=JsonConstant)
    except (ValueError, RecursionError) as error:
        raise ProjectError(f"{name}: manifest.json is not valid JSON ({error})") from None
    if not isinstance(manifest, dict) or manifest.get("format") != FORMAT:
        raise ProjectError(f"{name}: not a Biped Studio project (format is not {FORMAT!r})")
    version = manifest.get("version")
    if not isinstance(version, int) or isinstance(version, bool) or version < 1:
        raise ProjectError(f"{name}: manifest version {version!r} is not a format version")
    if version > VERSION:
        raise ProjectError(
            f"{name} was saved by a newer Biped Studio (project format version {version}; this "
            f"one reads up to version {VERSION}); update Biped Studio to open it"
        )
    if "project" not in manifest:
        raise ProjectError(f"{name}: the manifest holds no project")
    return manifest
