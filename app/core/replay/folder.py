"""The replay folder: everything a browser needs to play a recording from any static web
server, and nothing of the studio.

    DIR/index.html       opens viewer.html?playbackPath=recording.viser
    DIR/viewer.html      viser's built client (one self-contained page)
    DIR/recording.viser  the recording
    DIR/replay.json      what it shows (title, duration, frames, viser version)
    DIR/README.txt       how to open it

The folder is built beside DIR and moved into place whole, so a failed export leaves what was
at DIR untouched. DIR may be missing, empty, or an earlier replay (its replay.json says
FORMAT and it holds only the files above); anything else is refused, and nothing outside DIR
is ever removed (the earlier replay is moved aside under a fresh name of our own while the
new one moves in). An existing DIR.zip is replaced only when asked (`force`).
"""

from __future__ import annotations

import dataclasses
import html
import json
import os
import shutil
import tempfile
import zipfile
from pathlib import Path

from app.core.replay.legend import with_overlay
from app.core.replay.scene import ReplayError

INDEX = "index.html"
VIEWER = "viewer.html"
RECORDING = "recording.viser"
MANIFEST = "replay.json"
README = "README.txt"
FORMAT = "biped-studio-replay"
FORMAT_VERSION = 1


@dataclasses.dataclass(frozen=True)
class ReplayFolder:
    """An exported replay."""

    path: Path
    zip_path: Path | None
    recording_bytes: int
    total_bytes: int
    """Size of the folder's files [bytes]."""


def index_html(title: str) -> str:
    """The landing page: forwards to the viewer with the recording, and links it for browsers
    with scripts off."""
    target = f"{VIEWER}?playbackPath={RECORDING}"
    heading = html.escape(title.splitlines()[0] if title else "Biped Studio replay")
    return (
        '<!doctype html>\n<html><head><meta charset="utf-8">\n'
        f"<title>{heading}</title>\n"
        # From a server: straight to the viewer. From disk (file://) browsers refuse to fetch
        # the recording, so the page stays and says what to do.
        f'<script>if (location.protocol !== "file:") location.replace({json.dumps(target)});'
        "</script>\n"
        "</head><body>\n"
        f'<p><a href="{target}">Play the replay: {heading}</a></p>\n'
        "<p>Serve this folder over HTTP (e.g. <code>python -m http.server</code> in it); "
        "browsers do not let a page opened from a file fetch the recording.</p>\n"
        "</body></html>\n"
    )


def write_replay_folder(
    out: Path,
    recording: bytes,
    client_html: Path,
    title: str,
    manifest: dict[str, object],
    make_zip: bool = False,
    force: bool = False,
    overlay: str = "",
) -> ReplayFolder:
    """Write the replay folder at `out` (and `out.zip` beside it when asked; an existing zip
    is replaced only with `force`); `overlay` is HTML added to the viewer page
    (app.core.replay.legend)."""
    out = check_replay_target(out, make_zip, force)
    parent = out.parent
    try:
        parent.mkdir(parents=True, exist_ok=True)
        staging = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=parent))
    except OSError as error:
        raise ReplayError(f"cannot write the replay beside {out}: {error.strerror}") from None
    try:
        staging.chmod(0o755)  # mkdtemp makes it private; a web server must read it
        if overlay:
            page = Path(client_html).read_text(encoding="utf-8")
            (staging / VIEWER).write_text(with_overlay(page, overlay), encoding="utf-8")
        else:
            shutil.copyfile(client_html, staging / VIEWER)
        (staging / RECORDING).write_bytes(recording)
        (staging / INDEX).write_text(index_html(title), encoding="utf-8")
        info = {"format": FORMAT, "version": FORMAT_VERSION, "title": title, **manifest}
        (staging / MANIFEST).write_text(json.dumps(info, indent=2) + "\n", encoding="utf-8")
        (staging / README).write_text(_readme(title), encoding="utf-8")
        for file in staging.iterdir():
            with open(file, "rb") as handle:
                os.fsync(handle.fileno())
        zip_path = _zip(staging, out) if make_zip else None
        _swap_into_place(staging, out)
    except OSError as error:
        shutil.rmtree(staging, ignore_errors=True)
        raise ReplayError(f"cannot write the replay to {out}: {error}") from None
    total = sum(f.stat().st_size for f in out.iterdir())
    return ReplayFolder(out, zip_path, len(recording), total)


OWN_FILES = frozenset({INDEX, VIEWER, RECORDING, MANIFEST, README})


def check_replay_target(out: Path, make_zip: bool = False, force: bool = False) -> Path:
    """`out` made absolute, if a replay may be written there: missing, an empty folder or an
    earlier replay of ours; with `make_zip`, no `out.zip` unless `force`. ReplayError (one
    line) otherwise: call it before recording, so a refusal costs nothing."""
    out = Path(os.path.normpath(Path(out).absolute()))  # "." and "a/.." have a name and a parent
    if out.is_symlink() or (out.exists() and not out.is_dir()):
        raise ReplayError(f"{out} exists and is not a folder; choose another --out")
    if out.is_dir() and any(out.iterdir()) and not _is_own_replay(out):
        raise ReplayError(
            f"{out} is a folder holding files this export did not write; "
            "choose an empty or new folder"
        )
    archive = out.with_name(out.name + ".zip")
    if make_zip and (archive.exists() or archive.is_symlink()) and not force:
        raise ReplayError(f"{archive} exists; pass --force to replace it, or choose another --out")
    return out


def _is_own_replay(folder: Path) -> bool:
    """An earlier export: only our files, plain ones, and a replay.json that says so."""
    try:
        entries = list(folder.iterdir())
        if any(e.name not in OWN_FILES or e.is_symlink() or not e.is_file() for e in entries):
            return False
        info = json.loads((folder / MANIFEST).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False
    return isinstance(info, dict) and info.get("format") == FORMAT


def _swap_into_place(staging: Path, out: Path) -> None:
    """Move the finished folder to `out`, replacing an earlier replay (or an empty folder).
    The earlier one waits under a fresh name of our own (never a name someone else uses)."""
    old = None
    if out.exists():
        old = Path(tempfile.mkdtemp(prefix=f".{out.name}.old.", dir=out.parent))
        out.rename(old)  # over the fresh empty folder
    try:
        staging.rename(out)
    except OSError:
        if old is not None:
            old.rename(out)
        raise
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)


def _zip(staging: Path, out: Path) -> Path:
    """`out.zip`: the folder's files under `out.name/` (written whole, then renamed)."""
    target = out.with_name(out.name + ".zip")
    partial = target.with_name(f".{target.name}.partial")
    with zipfile.ZipFile(partial, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        for file in sorted(staging.iterdir()):
            # The recording is already zstd-compressed: stored, not deflated again.
            kind = zipfile.ZIP_STORED if file.name == RECORDING else zipfile.ZIP_DEFLATED
            archive.write(file, f"{out.name}/{file.name}", compress_type=kind)
    partial.replace(target)
    return target


def _readme(title: str) -> str:
    return (
        f"{title}\n\n"
        "A replay exported by Biped Studio. To watch it, serve this folder over HTTP and open\n"
        "index.html, e.g.\n\n"
        "    cd THIS_FOLDER && python3 -m http.server 8000\n"
        "    then open http://127.0.0.1:8000/\n\n"
        "or `biped-studio replay open THIS_FOLDER`. Nothing else needs to be installed: the\n"
        "viewer (viser's web client) is viewer.html, the recording is recording.viser.\n"
    )


def check_replay_folder(folder: Path) -> Path:
    """The folder, resolved, if it can be served as a replay: a folder with an index.html, no
    link inside it pointing outside it. ReplayError otherwise."""
    folder = Path(folder)
    if not folder.is_dir():
        raise ReplayError(f"{folder} is not a folder")
    root = folder.resolve()
    index = folder / INDEX
    if not index.is_file() or index.is_symlink():
        raise ReplayError(f"{folder} has no index.html: not a replay folder")
    for dirpath, dirnames, filenames in os.walk(folder):
        for name in dirnames + filenames:
            path = Path(dirpath) / name
            if path.is_symlink() and not _inside(path.resolve(), root):
                raise ReplayError(f"{path} links outside the replay folder; refusing to serve it")
    return root


def _inside(path: Path, root: Path) -> bool:
    return path == root or root in path.parents
