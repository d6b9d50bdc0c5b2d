"""Uploaded robots: a .urdf or a .zip (URDF + meshes) unpacked safely into its own folder.

Each upload gets a fresh folder under the uploads root, named by the content's hash, marked
by an UPLOAD_MARKER file: a URDF anywhere below it is confined to that folder however it is
opened later (app.core.robot.loading), so the whole unpacked archive is the upload's sandbox
and `package://NAME/…` finds the folder NAME inside it or the archive's root (a ROS
description package zipped as `urdf/robot.urdf` + `meshes/…`).

Nothing is written outside it, and every archive is checked whole before a byte is unpacked:

- size ≤ MAX_UPLOAD_BYTES (100 MiB), unpacked ≤ MAX_UNPACKED_BYTES (500 MiB), ≤ MAX_ENTRIES
  (5 000) entries (zip bombs);
- no absolute paths, `..` components, drive letters, symbolic links, NUL characters;
- names ≤ MAX_NAME_CHARS (512) characters, each component ≤ MAX_PART_BYTES (200) bytes;
- no two entries whose names collide (same path up to case, or a file also used as a folder);
- no encrypted entries, and only stored / deflate / bzip2 / lzma compression;
- an entry that unpacks to more or fewer bytes than its header says, or fails its CRC, stops
  the unpack.

The archive is unpacked into a temporary folder beside the final one and renamed into place
only when complete, so a failed unpack leaves no half-written folder. Every failure of the
zip library (bad CRC, truncated data, unsupported feature) becomes an UploadError.

The store keeps at most MAX_STORED_UPLOADS (32) uploads and MAX_STORE_BYTES (1 GiB); before an
upload is stored, the oldest uploads (by modification time) are removed until it fits.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import os
import re
import shutil
import stat
import tempfile
import zipfile
import zlib
from pathlib import Path, PurePosixPath

from app.core.errors import UploadError

MAX_UPLOAD_BYTES = 100 * 1024 * 1024
MAX_UNPACKED_BYTES = 500 * 1024 * 1024
MAX_ENTRIES = 5000
MAX_NAME_CHARS = 512
MAX_PART_BYTES = 200
MAX_STORED_UPLOADS = 32
MAX_STORE_BYTES = 1024 * 1024 * 1024
UPLOAD_MARKER = ".biped-studio-upload"
"""Empty file at the top of every upload folder: a URDF below it is confined to that folder."""
SUPPORTED_COMPRESSION = {
    zipfile.ZIP_STORED: "stored",
    zipfile.ZIP_DEFLATED: "deflate",
    zipfile.ZIP_BZIP2: "bzip2",
    zipfile.ZIP_LZMA: "lzma",
}
_ZIP_FAILURES = (
    zipfile.BadZipFile,
    zipfile.LargeZipFile,
    zlib.error,
    EOFError,
    NotImplementedError,
    RuntimeError,
    ValueError,
    OSError,
)


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
    root = uploads_root.resolve()
    folder = root / digest
    if suffix == ".urdf":
        name = _safe_name(filename)
        plan: dict[str, bytes] | zipfile.ZipFile = {name: content}
        urdf, unpacked = name, len(content)
    else:
        archive = _open_zip(filename, content)
        plan = archive
        urdf, unpacked = _check_archive(filename, archive)
    target = folder.joinpath(*PurePosixPath(urdf).parts)
    if (folder / UPLOAD_MARKER).is_file() and target.is_file():
        os.utime(folder)  # the same content again: reuse it, newest in the store
        return target
    try:
        root.mkdir(parents=True, exist_ok=True)
        make_room(root, unpacked, keep=folder)
        _unpack(filename, plan, root, folder)
    except OSError as exc:
        raise UploadError(f"{filename}: cannot store the upload: {exc.strerror or exc}") from None
    return target


def _open_zip(filename: str, content: bytes) -> zipfile.ZipFile:
    try:
        return zipfile.ZipFile(io.BytesIO(content))
    except _ZIP_FAILURES as exc:
        raise UploadError(f"{filename}: not a valid zip archive ({exc})") from None


def _check_archive(filename: str, archive: zipfile.ZipFile) -> tuple[str, int]:
    """(the URDF's entry name, unpacked bytes) of an archive that passed every check."""
    entries = archive.infolist()
    if len(entries) > MAX_ENTRIES:
        raise UploadError(f"{filename}: {len(entries)} entries, over the limit of {MAX_ENTRIES}")
    unpacked = sum(entry.file_size for entry in entries)
    if unpacked > MAX_UNPACKED_BYTES:
        raise UploadError(
            f"{filename}: unpacks to {unpacked / 2**20:.0f} MB, over the {MAX_UNPACKED_BYTES / 2**20:.0f} MB limit"
        )
    seen: dict[str, str] = {}
    folders: set[str] = set()
    for entry in entries:
        _check_entry(filename, entry)
        parts = PurePosixPath(entry.filename).parts
        key = "/".join(parts).casefold()
        if key in seen:
            raise UploadError(
                f"{filename}: entries {seen[key]!r} and {entry.filename!r} unpack to the same "
                "file; refused (nothing was unpacked)"
            )
        seen[key] = entry.filename
        folders.update("/".join(parts[:i]).casefold() for i in range(1, len(parts)))
    clash = [seen[key] for key in folders if key in seen and not seen[key].endswith("/")]
    if clash:
        raise UploadError(
            f"{filename}: entry {clash[0]!r} is both a file and a folder; refused (nothing was unpacked)"
        )
    urdfs = [e.filename for e in entries if e.filename.lower().endswith(".urdf") and not e.is_dir()]
    if not urdfs:
        raise UploadError(f"{filename}: the archive holds no .urdf file")
    urdfs.sort(key=lambda name: (name.count("/"), name))
    return urdfs[0], unpacked


def _check_entry(filename: str, entry: zipfile.ZipInfo) -> None:
    name = entry.filename
    path = PurePosixPath(name.replace("\\", "/"))
    if not name or path.is_absolute() or ".." in path.parts or re.match(r"^[A-Za-z]:", name):
        raise UploadError(
            f"{filename}: entry {name!r} points outside the archive's folder; refused (nothing was unpacked)"
        )
    if "\x00" in name or len(name) > MAX_NAME_CHARS:
        shown = name[:60] + "…" if len(name) > 60 else name
        raise UploadError(
            f"{filename}: entry {shown!r} has a name of {len(name)} characters or a NUL; "
            f"names up to {MAX_NAME_CHARS} characters are accepted"
        )
    for part in path.parts:
        if len(part.encode("utf-8", "surrogateescape")) > MAX_PART_BYTES:
            raise UploadError(
                f"{filename}: entry {name[:60]!r}… has a path component longer than "
                f"{MAX_PART_BYTES} bytes; refused"
            )
    if stat.S_ISLNK(entry.external_attr >> 16):
        raise UploadError(
            f"{filename}: entry {name!r} is a symbolic link; refused (nothing was unpacked)"
        )
    if entry.flag_bits & 0x1:
        raise UploadError(
            f"{filename}: entry {name!r} is encrypted; upload an archive without a password"
        )
    if entry.compress_type not in SUPPORTED_COMPRESSION:
        raise UploadError(
            f"{filename}: entry {name!r} uses compression method {entry.compress_type}; "
            f"re-zip with one of {', '.join(SUPPORTED_COMPRESSION.values())}"
        )


def _unpack(
    filename: str, plan: dict[str, bytes] | zipfile.ZipFile, root: Path, folder: Path
) -> None:
    """Write everything into a temporary folder under `root`, then rename it to `folder`."""
    staging = Path(tempfile.mkdtemp(prefix=".incoming-", dir=root))
    try:
        if isinstance(plan, dict):
            for name, data in plan.items():
                (staging / name).write_bytes(data)
        else:
            with plan:
                for entry in plan.infolist():
                    _unpack_entry(filename, plan, entry, staging)
        (staging / UPLOAD_MARKER).touch()
        if folder.exists():  # a damaged earlier copy of the same content
            shutil.rmtree(folder)
        os.rename(staging, folder)
    except _ZIP_FAILURES as exc:
        shutil.rmtree(staging, ignore_errors=True)
        if isinstance(exc, OSError) and not isinstance(exc, zipfile.BadZipFile):
            raise UploadError(
                f"{filename}: cannot unpack: {exc.strerror or exc}; nothing was kept"
            ) from None
        raise UploadError(f"{filename}: damaged archive ({exc}); nothing was kept") from None
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise


def _unpack_entry(
    filename: str, archive: zipfile.ZipFile, entry: zipfile.ZipInfo, staging: Path
) -> None:
    target = staging.joinpath(*PurePosixPath(entry.filename).parts)
    if entry.is_dir():
        target.mkdir(parents=True, exist_ok=True)
        return
    target.parent.mkdir(parents=True, exist_ok=True)
    with archive.open(entry) as source, open(target, "wb") as sink:
        written = 0
        while chunk := source.read(1 << 20):
            written += len(chunk)
            if written > entry.file_size:
                raise UploadError(
                    f"{filename}: entry {entry.filename!r} unpacks to more than its header says; "
                    "refused (nothing was kept)"
                )
            sink.write(chunk)
    if written != entry.file_size:
        raise UploadError(
            f"{filename}: entry {entry.filename!r} holds {written} bytes, its header says "
            f"{entry.file_size}; refused (nothing was kept)"
        )


def make_room(root: Path, incoming_bytes: int, keep: Path | None = None) -> list[Path]:
    """Remove the oldest uploads until one more of `incoming_bytes` fits the store's quota
    (MAX_STORED_UPLOADS uploads, MAX_STORE_BYTES in all); return the folders removed.
    Left-over `.incoming-*` folders of an interrupted unpack are removed as well."""
    for stale in root.glob(".incoming-*"):
        shutil.rmtree(stale, ignore_errors=True)
    uploads = []
    for folder in root.iterdir():
        if folder != keep and (folder / UPLOAD_MARKER).is_file():
            uploads.append((folder.stat().st_mtime, folder, _folder_bytes(folder)))
    uploads.sort()
    total = sum(size for _, _, size in uploads)
    removed = []
    while uploads and (
        len(uploads) + 1 > MAX_STORED_UPLOADS or total + incoming_bytes > MAX_STORE_BYTES
    ):
        _, folder, size = uploads.pop(0)
        shutil.rmtree(folder, ignore_errors=True)
        total -= size
        removed.append(folder)
    return removed


def _folder_bytes(folder: Path) -> int:
    total = 0
    for path in folder.rglob("*"):
        with contextlib.suppress(OSError):
            if path.is_file() and not path.is_symlink():
                total += path.stat().st_size
    return total


def _safe_name(filename: str) -> str:
    name = re.sub(r"[^A-Za-z0-9._-]", "_", Path(filename).name)
    name = name.lstrip(".")[-100:].lstrip(".")
    return name if name.lower().endswith(".urdf") else "robot.urdf"
