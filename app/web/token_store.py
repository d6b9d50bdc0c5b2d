"""The access token kept in the data folder, so that a restarted studio answers the links and
cookies of the tabs still open (a new token per run left every open tab on "needs its access
link").

The token lives in `DATA/access-token`: one line, 43 URL-safe characters, a regular file of
this user readable by them only (0600), in a data folder created 0700. It is reused on every
start; `rotate` (`biped-studio serve --new-token`) replaces it, and links opened before stop
working. A stored token that cannot be trusted (readable or writable by others, not this
user's, not a plain file, not a token) is replaced by a new one with one line saying why: a
token that other users could read may be known to them.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import re
import stat
import tempfile
from pathlib import Path

from app.web.access import new_token

TOKEN_FILE = "access-token"
_TOKEN = re.compile(r"[A-Za-z0-9_-]{32,128}")
"""What a stored token must look like: `secrets.token_urlsafe(32)` gives 43 such characters;
a shorter hand-written one is refused (guessable)."""
_MAX_BYTES = 256


@dataclasses.dataclass(frozen=True)
class StoredToken:
    """The token to serve with, and what the user must be told about it."""

    token: str
    path: Path
    warning: str = ""
    """One line when the stored token was replaced or cannot be kept; "" when all is well."""
    created: bool = False
    """The token is new (first start, rotated, or the stored one was refused)."""


def stored_token(data_dir: Path, rotate: bool = False) -> StoredToken:
    """The token kept in `data_dir` (made and kept there when there is none, or on `rotate`)."""
    path = Path(data_dir) / TOKEN_FILE
    warning = ""
    if not rotate:
        try:
            token = _read(path)
        except FileNotFoundError:
            token = None
        except _Untrusted as why:
            token, warning = None, f"the access token in {path} {why}; made a new one"
        if token is not None:
            return StoredToken(token, path)
    token = new_token()
    try:
        _write(path, token)
    except OSError as error:
        reason = error.strerror or type(error).__name__
        warning = (
            f"the access token cannot be kept in {path} ({reason}); this run's link stops "
            "working when the studio stops"
        )
    return StoredToken(token, path, warning, created=True)


class _Untrusted(Exception):
    """The stored token is there but must not be used; the message says why."""


def _read(path: Path) -> str:
    """The stored token; FileNotFoundError if none, _Untrusted if it cannot be trusted."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK)
    except FileNotFoundError:
        if path.is_symlink():  # a dangling link
            raise _Untrusted("is a symbolic link, not a file") from None
        raise
    except OSError as error:  # a link (ELOOP), a folder, no permission...
        if path.is_symlink():
            raise _Untrusted("is a symbolic link, not a file") from None
        raise _Untrusted(f"cannot be read ({error.strerror or error})") from None
    try:
        info = os.fstat(fd)
        if not stat.S_ISREG(info.st_mode):
            raise _Untrusted("is not a plain file")
        if info.st_uid != os.getuid():
            raise _Untrusted("belongs to another user")
        if info.st_mode & 0o077:
            mode = f"{stat.S_IMODE(info.st_mode):04o}"
            raise _Untrusted(f"could be read or changed by other users (mode {mode}, not 0600)")
        data = os.read(fd, _MAX_BYTES + 1)
    finally:
        os.close(fd)
    try:
        text = data.decode("ascii").strip()
    except UnicodeDecodeError:
        text = ""
    if len(data) > _MAX_BYTES or not _TOKEN.fullmatch(text):
        raise _Untrusted("is not a token (damaged or edited)")
    return text


def _write(path: Path, token: str) -> None:
    """Replace the stored token whole (temporary file 0600, fsync, rename); the data folder is
    created 0700 when missing."""
    folder = path.parent
    if not folder.is_dir():
        folder.mkdir(mode=0o700, parents=True, exist_ok=True)
    fd, temporary = tempfile.mkstemp(prefix=".access-token-", dir=folder)  # mode 0600
    try:
        with os.fdopen(fd, "w", encoding="ascii") as file:
            os.fchmod(file.fileno(), 0o600)
            file.write(token + "\n")
            file.flush()
            os.fsync(file.fileno())
        os.replace(temporary, path)  # a link or a bad file at `path` is replaced, not followed
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(temporary)
        raise
