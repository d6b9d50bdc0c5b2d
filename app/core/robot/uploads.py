"""Uploaded robots: a .urdf or a .zip (URDF + meshes) unpacked safely into its own folder.

Each upload gets a fresh folder under the uploads root, named by the content's hash. Nothing
is written outside it: archive entries with absolute paths, `..` components or symbolic links
are refused, and so are archives whose size, unpacked size or entry count is over the caps
(zip bombs). Mesh look-ups of an uploaded robot are confined to its folder.
"""

from __future__ import annotations

import hashlib
import io
import os
import re
import stat
import zipfile
from pathlib import Path, PurePosixPath

from app.core.errors import UploadError

MAX_UPLOAD_BYTES = 100 * 1024 * 1024
MAX_UNPACKED_BYTES = 500 * 1024 * 1024
MAX_ENTRIES = 5000
UPLOAD_MARKER = ".biped-studio-upload"
"""Empty file at the top of every upload folder: a URDF below it is confined to that folder."""


def upload_sandbox_of(path: Path) -> Path | None:
    """The outermost upload folder holding `path` (links followed), or None."""
    resolved = Path(os.path.realpath(path))
    found = None
    for ancestor in resolved.parents:
        if (ancestor / UPLOAD_MARKER).is_file():
            found = ancestor
    return found


def store_upload(
    filename: str, content: bytes, uploads_root: Path, max_bytes: int = MAX_UPLOAD_BYTES
) -> Path:
    """Write an uploaded .urdf or unpack an uploaded .zip; return the URDF's path inside its folder."""
    if len(content) > max_bytes:
        raise UploadError(
            f"{filename} is {len(content) / 2**20:.1f} MB, over the {max_bytes / 2**20:.0f} MB upload limit; "
            "drop unused meshes or simplify them, or load the robot from a path instead"
        )
    suffix = Path(filename).suffix.lower()
    if suffix not in (".urdf", ".zip"):
        raise UploadError(
            f"{filename}: upload a .urdf file, or a .zip holding the URDF and its meshes"
        )
    digest = hashlib.sha256(content).hexdigest()[:16]
    folder = uploads_root.resolve() / digest
    if suffix == ".urdf":
        folder.mkdir(parents=True, exist_ok=True)
        target = folder / _safe_name(filename)
        target.write_bytes(content)
        return target
    return _unpack_zip(filename, content, folder)


def _unpack_zip(filename: str, content: bytes, folder: Path) -> Path:
    try:
        archive = zipfile.ZipFile(io.BytesIO(content))
    except zipfile.BadZipFile:
        raise UploadError(f"{filename}: not a valid zip archive") from None
    with archive:
        entries = archive.infolist()
        if len(entries) > MAX_ENTRIES:
            raise UploadError(
                f"{filename}: {len(entries)} entries, over the limit of {MAX_ENTRIES}"
            )
        unpacked = sum(entry.file_size for entry in entries)
        if unpacked > MAX_UNPACKED_BYTES:
            raise UploadError(
                f"{filename}: unpacks to {unpacked / 2**20:.0f} MB, over the {MAX_UNPACKED_BYTES / 2**20:.0f} MB limit"
            )
        for entry in entries:
            _check_entry(filename, entry)
        urdfs = [
            e.filename for e in entries if e.filename.lower().endswith(".urdf") and not e.is_dir()
        ]
        if not urdfs:
            raise UploadError(f"{filename}: the archive holds no .urdf file")
        folder.mkdir(parents=True, exist_ok=True)
        for entry in entries:
            target = folder.joinpath(*PurePosixPath(entry.filename).parts)
            if entry.is_dir():
                target.mkdir(parents=True, exist_ok=True)
                continue
            target.parent.mkdir(parents=True, exist_ok=True)
            with archive.open(entry) as source, open(target, "wb") as sink:
                _copy_capped(source, sink, entry.file_size, filename)
    urdfs.sort(key=lambda name: (name.count("/"), name))
    return folder.joinpath(*PurePosixPath(urdfs[0]).parts)


def _check_entry(filename: str, entry: zipfile.ZipInfo) -> None:
    name = entry.filename
    path = PurePosixPath(name.replace("\\", "/"))
    if path.is_absolute() or ".." in path.parts or re.match(r"^[A-Za-z]:", name):
        raise UploadError(
            f"{filename}: entry {name!r} points outside the archive's folder; refused (nothing was unpacked)"
        )
    mode = entry.external_attr >> 16
    if stat.S_ISLNK(mode):
        raise UploadError(
            f"{filename}: entry {name!r} is a symbolic link; refused (nothing was unpacked)"
        )


def _copy_capped(source, sink, declared: int, filename: str) -> None:
    """Copy at most the declared size: a lying header cannot unpack more than it announced."""
    written = 0
    while chunk := source.read(1 << 20):
        written += len(chunk)
        if written > declared:
            raise UploadError(f"{filename}: an entry unpacks to more than its header says; refused")
        sink.write(chunk)


def _safe_name(filename: str) -> str:
    name = re.sub(r"[^A-Za-z0-9._-]", "_", Path(filename).name)
    return name.lstrip(".") or "robot.urdf"
