"""The replay's pure parts: frame sampling, the folder writer and checker, the .viser reader."""

from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np
import pytest
import zstandard

from app.core.motions.library import run_motion
from app.core.replay.folder import (
    INDEX,
    MANIFEST,
    RECORDING,
    VIEWER,
    check_replay_folder,
    write_replay_folder,
)
from app.core.replay.scene import ReplayError, frame_samples, title_card
from app.core.replay.viser_file import read_viser_file
from app.core.robot.loading import load_robot


@pytest.fixture(scope="module")
def trajectory():
    return run_motion(load_robot("servo_biped"), "com_shift").trajectory


@pytest.mark.parametrize("rate_hz", [10.0, 30.0, 60.0, 7.3])
def test_frames_are_the_samples_nearest_each_frame_time(trajectory, rate_hz):
    k = frame_samples(trajectory, rate_hz)
    # Brute force: for every frame time i/rate, the nearest sample time (ties either way).
    times = np.arange(len(k)) / rate_hz
    if k[-1] == trajectory.n_samples - 1 and times[-1] > trajectory.duration:
        times = times[:-1]
    for i, t in enumerate(times):
        assert abs(trajectory.t[k[i]] - min(t, trajectory.duration)) <= trajectory.dt / 2 + 1e-12
    assert k[0] == 0 and k[-1] == trajectory.n_samples - 1
    assert np.all(np.diff(k) >= 0)


@pytest.mark.parametrize("rate_hz", [0.0, -1.0, float("nan"), float("inf"), 61.0])
def test_bad_frame_rates_are_refused(trajectory, rate_hz):
    with pytest.raises(ReplayError, match="frame rate"):
        frame_samples(trajectory, rate_hz)


def test_title_card_drops_markdown():
    text = title_card("bot", "walk", 2.0, {"speed": "1"}, ("**stable**", "⚠️ fell"))
    assert text.splitlines() == ["bot — walk (2.0 s)", "speed = 1", "stable", "! fell"]


def _client(tmp_path: Path) -> Path:
    page = tmp_path / "client.html"
    page.write_text("<html>viewer</html>")
    return page


def test_folder_round_trip_and_replacing_an_earlier_replay(tmp_path):
    out = tmp_path / "replay"
    first = write_replay_folder(out, b"one", _client(tmp_path), "A", {"n": 1}, make_zip=True)
    assert (out / RECORDING).read_bytes() == b"one" and (out / VIEWER).exists()
    assert first.total_bytes == sum(p.stat().st_size for p in out.iterdir())
    with zipfile.ZipFile(first.zip_path) as archive:
        assert sorted(archive.namelist()) == sorted(f"replay/{p.name}" for p in out.iterdir())
    write_replay_folder(out, b"two", _client(tmp_path), "B", {"n": 2})
    assert (out / RECORDING).read_bytes() == b"two"
    assert '"title": "B"' in (out / MANIFEST).read_text()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["client.html", "replay", "replay.zip"]
    assert check_replay_folder(out) == out.resolve()


def test_a_file_or_a_foreign_folder_is_not_overwritten(tmp_path):
    target = tmp_path / "notes.txt"
    target.write_text("keep")
    with pytest.raises(ReplayError, match="not a folder"):
        write_replay_folder(target, b"x", _client(tmp_path), "t", {})
    assert target.read_text() == "keep"


def test_a_sibling_named_like_the_old_replay_is_left_alone(tmp_path):
    """The earlier replay moves aside under a fresh name: the user's own `.replay.old` (the
    name the writer once used and removed wholesale) is not touched."""
    out = tmp_path / "replay"
    write_replay_folder(out, b"one", _client(tmp_path), "A", {})
    theirs = tmp_path / ".replay.old"
    theirs.mkdir()
    (theirs / "thesis.tex").write_text("keep")
    write_replay_folder(out, b"two", _client(tmp_path), "B", {})
    assert (theirs / "thesis.tex").read_text() == "keep"
    assert (out / RECORDING).read_bytes() == b"two"
    assert sorted(p.name for p in tmp_path.iterdir()) == [".replay.old", "client.html", "replay"]


def test_a_replay_folder_holding_other_files_is_not_replaced(tmp_path):
    out = tmp_path / "replay"
    write_replay_folder(out, b"one", _client(tmp_path), "A", {})
    (out / "notes.md").write_text("mine")
    with pytest.raises(ReplayError, match="did not write"):
        write_replay_folder(out, b"two", _client(tmp_path), "B", {})
    assert (out / "notes.md").read_text() == "mine" and (out / RECORDING).read_bytes() == b"one"


def test_a_folder_whose_manifest_is_not_ours_is_not_replaced(tmp_path):
    out = tmp_path / "replay"
    out.mkdir()
    (out / MANIFEST).write_text('{"format": "someone-else"}')
    with pytest.raises(ReplayError, match="did not write"):
        write_replay_folder(out, b"x", _client(tmp_path), "t", {})
    assert (out / MANIFEST).read_text() == '{"format": "someone-else"}'


def test_an_existing_zip_is_kept_unless_forced(tmp_path):
    out = tmp_path / "replay"
    archive = tmp_path / "replay.zip"
    archive.write_bytes(b"the user's zip")
    with pytest.raises(ReplayError, match="--force"):
        write_replay_folder(out, b"one", _client(tmp_path), "A", {}, make_zip=True)
    assert archive.read_bytes() == b"the user's zip" and not out.exists()
    write_replay_folder(out, b"one", _client(tmp_path), "A", {}, make_zip=True, force=True)
    with zipfile.ZipFile(archive) as replaced:
        assert replaced.read("replay/recording.viser") == b"one"


def test_check_accepts_links_inside_and_refuses_links_outside(tmp_path):
    folder = tmp_path / "r"
    folder.mkdir()
    (folder / INDEX).write_text("x")
    (folder / "again.html").symlink_to(folder / INDEX)
    assert check_replay_folder(folder) == folder.resolve()
    (folder / "sub").mkdir()
    (folder / "sub" / "up").symlink_to(tmp_path)
    with pytest.raises(ReplayError, match="links outside"):
        check_replay_folder(folder)


def test_index_must_be_a_real_file(tmp_path):
    folder = tmp_path / "r"
    folder.mkdir()
    (tmp_path / "elsewhere.html").write_text("x")
    (folder / INDEX).symlink_to(tmp_path / "elsewhere.html")
    with pytest.raises(ReplayError, match="no index.html"):
        check_replay_folder(folder)
    with pytest.raises(ReplayError, match="not a folder"):
        check_replay_folder(tmp_path / "missing")


@pytest.mark.parametrize(
    "data",
    [
        b"",
        b"\x05\x00\x00\x00\x00\x00\x00\x00garbage",
        (1 << 40).to_bytes(8, "little") + b"x",
        (20).to_bytes(8, "little") + zstandard.ZstdCompressor().compress(b"\x00" * 20),
    ],
)
def test_reader_refuses_what_is_not_a_recording(data):
    with pytest.raises(ReplayError):
        read_viser_file(data)


def test_out_may_be_the_working_folder_when_empty(tmp_path, monkeypatch):
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    result = write_replay_folder(Path("."), b"rec", _client(tmp_path), "t", {})
    assert result.path == work and (work / RECORDING).read_bytes() == b"rec"
