"""The access token kept in the data folder: made once (0600, in a 0700 folder), reused on the
next start, replaced on request, and replaced with one line of warning when the stored one
cannot be trusted (other users could read it, not a plain file, not a token)."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest

from app.config import StudioConfig
from app.web.access import AccessPolicy
from app.web.token_store import TOKEN_FILE, stored_token


def _mode(path: Path) -> int:
    return stat.S_IMODE(path.lstat().st_mode)


def test_the_token_is_made_once_private_and_reused(tmp_path: Path) -> None:
    data = tmp_path / "nested" / "data"
    first = stored_token(data)
    assert first.created and first.warning == ""
    assert first.path == data / TOKEN_FILE
    assert _mode(data) == 0o700 and _mode(first.path) == 0o600
    assert first.path.read_text() == first.token + "\n"
    AccessPolicy("127.0.0.1", first.token)  # a token the web guard accepts
    again = stored_token(data)
    assert again.token == first.token and not again.created and again.warning == ""
    assert [p.name for p in data.iterdir()] == [TOKEN_FILE]  # no temporary file left


def test_rotate_makes_a_new_token_and_keeps_it(tmp_path: Path) -> None:
    old = stored_token(tmp_path).token
    new = stored_token(tmp_path, rotate=True)
    assert new.token != old and new.created and new.warning == ""
    assert stored_token(tmp_path).token == new.token
    assert _mode(new.path) == 0o600


@pytest.mark.parametrize("mode", [0o644, 0o640, 0o602])
def test_a_token_other_users_could_read_or_change_is_replaced(tmp_path: Path, mode: int) -> None:
    old = stored_token(tmp_path)
    os.chmod(old.path, mode)
    new = stored_token(tmp_path)
    assert new.token != old.token and new.created
    assert f"mode {mode:04o}" in new.warning and "made a new one" in new.warning
    assert "\n" not in new.warning
    assert _mode(new.path) == 0o600


@pytest.mark.parametrize(
    "content", [b"", b"short\n", b"x" * 43 + b" y\n", "é".encode() * 40, b"a" * 5000]
)
def test_a_damaged_token_file_is_replaced(tmp_path: Path, content: bytes) -> None:
    path = stored_token(tmp_path).path
    path.write_bytes(content)
    os.chmod(path, 0o600)
    new = stored_token(tmp_path)
    assert "is not a token" in new.warning and new.created
    assert path.read_text() == new.token + "\n"


def test_a_link_in_place_of_the_file_is_replaced_and_its_target_left_alone(
    tmp_path: Path,
) -> None:
    data = tmp_path / "data"
    data.mkdir(mode=0o700)
    elsewhere = tmp_path / "elsewhere"
    token_like = "A" * 43
    elsewhere.write_text(token_like)
    os.chmod(elsewhere, 0o600)
    (data / TOKEN_FILE).symlink_to(elsewhere)
    new = stored_token(data)
    assert new.token != token_like and "symbolic link" in new.warning
    assert not (data / TOKEN_FILE).is_symlink() and elsewhere.read_text() == token_like


def test_a_data_folder_that_cannot_hold_it_still_serves_with_a_warning(tmp_path: Path) -> None:
    blocked = tmp_path / "a-file"
    blocked.write_text("not a folder")
    result = stored_token(blocked)
    assert "cannot be kept" in result.warning and len(result.token) == 43


def test_the_config_settles_its_token_from_the_data_folder(tmp_path: Path) -> None:
    config = StudioConfig(data_dir=tmp_path)
    with pytest.raises(ValueError):
        _ = config.access_token  # never taken for "no token"
    settled, warning = config.settle_token()
    assert warning == "" and settled.access_token == stored_token(tmp_path).token
    assert settled.settle_token() == (settled, "")
    rotated, _ = StudioConfig(data_dir=tmp_path, new_token=True).settle_token()
    assert rotated.token != settled.token
    off, _ = StudioConfig(data_dir=tmp_path / "off", no_token=True).settle_token()
    assert off.access_token is None and not (tmp_path / "off").exists()
