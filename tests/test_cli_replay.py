"""`biped-studio replay export` and `replay open`, run as a user runs them: subprocesses, files,
and the recording read back independently of the code that wrote it."""

from __future__ import annotations

import json
import re
import subprocess
import sys
import urllib.error
import urllib.request
import zipfile
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from app.core.motions.library import run_motion
from app.core.quaternions import wxyz_to_matrix
from app.core.replay.folder import INDEX, MANIFEST, RECORDING, VIEWER
from app.core.replay.viser_file import read_viser_file
from app.core.robot.loading import load_robot

FPS = 20.0


def run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "app", *args], capture_output=True, text=True, check=False
    )


@pytest.fixture(scope="module")
def exported(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("replays") / "com_shift"
    result = run(
        "replay", "export", "--robot", "servo_biped", "--motion", "com_shift",
        "--fps", str(FPS), "--out", str(out), "--zip", "--json",
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    assert report["ok"] and report["out"] == str(out)
    return out


def _world_poses_at(messages, time_s: float, prefix: str) -> dict[str, np.ndarray]:
    """World 4×4 placement of every node under `prefix` at `time_s`, from the last position
    and orientation each node was sent, composed along the node paths (viser's nesting)."""
    local: dict[str, np.ndarray] = {}
    for t, m in messages:
        if t > time_s + 1e-9 or not str(m.get("name", "")).startswith(prefix):
            continue
        T = local.setdefault(m["name"], np.eye(4))
        if m["type"] == "SetPositionMessage":
            T[:3, 3] = m["position"]
        elif m["type"] == "SetOrientationMessage":
            T[:3, :3] = wxyz_to_matrix(np.asarray(m["wxyz"]))
    world = {}
    for name in local:
        T, path = np.eye(4), name
        while path.startswith(prefix):
            T = local.get(path, np.eye(4)) @ T
            path = path.rsplit("/", 1)[0]
        world[name] = T
    return world


def test_export_writes_a_self_contained_folder_and_zip(exported: Path):
    assert {p.name for p in exported.iterdir()} >= {INDEX, VIEWER, RECORDING, MANIFEST}
    index = (exported / INDEX).read_text()
    assert f"{VIEWER}?playbackPath={RECORDING}" in index
    # The viewer is viser's own built client, byte for byte, with the legend card as the
    # first thing in its body (app/core/replay/legend.py).
    import viser

    client = Path(viser.__file__).parent / "client" / "build" / "index.html"
    viewer = (exported / VIEWER).read_text(encoding="utf-8")
    page = client.read_text(encoding="utf-8")
    at, added = page.index("<body>") + len("<body>"), len(viewer) - len(page)
    assert viewer[at : at + added].startswith('\n<div id="replay-legend"')
    assert viewer[:at] + viewer[at + added :] == page
    with zipfile.ZipFile(exported.with_name("com_shift.zip")) as archive:
        for path in exported.iterdir():
            assert archive.read(f"com_shift/{path.name}") == path.read_bytes()


def test_recording_decodes_to_the_robot_following_the_motion(exported: Path):
    robot = load_robot("servo_biped")
    trajectory = run_motion(robot, "com_shift").trajectory
    recording = read_viser_file((exported / RECORDING).read_bytes())
    assert recording.duration_s == pytest.approx(trajectory.duration, abs=1.0 / FPS)
    names = recording.node_names()
    # Every visual mesh of the robot, and the same robot once per ghost, plus the title card.
    n_visual = sum(m.role == "visual" for m in robot.meshes)
    for root in ("/robot", "/ghosts/planned", "/ghosts/command", "/ghosts/without", "/ghosts/with"):
        assert sum(n.startswith(root + "/") and "/visual_" in n for n in names) == n_visual
    assert "/title" in names
    title = next(
        m for _, m in recording.messages if m["name" if "name" in m else "type"] == "/title"
    )
    assert "servo_biped" in title["props"]["text"] and "com_shift" in title["props"]["text"]
    # At a few times, the recorded robot's links sit where pinocchio puts them for the
    # motion's sample at that time (positions compared as sets: node names are not link names).
    data = robot.model.createData()
    for time_s in (0.0, trajectory.duration / 2, trajectory.duration):
        k = trajectory.index_at(time_s)
        pin.framesForwardKinematics(robot.model, data, trajectory.q[k])
        expected = np.array([data.oMf[i].translation for i in robot.link_frame_ids.values()])
        poses = _world_poses_at(recording.messages, time_s, "/robot/links")
        links = [
            T[:3, 3] for name, T in poses.items() if re.fullmatch(r"/robot/links(/\d+)+", name)
        ]
        got = np.array(links)
        assert len(got) == len(expected)
        distances = np.linalg.norm(expected[:, None, :] - got[None, :, :], axis=2)
        assert distances.min(axis=1).max() < 1e-6


def test_replay_open_serves_the_folder_on_loopback(exported: Path):
    server = subprocess.Popen(
        [sys.executable, "-m", "app", "replay", "open", str(exported), "--port", "0"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert server.stdout is not None
        line = server.stdout.readline()
        match = re.search(r"http://127\.0\.0\.1:(\d+)/", line)
        assert match, line
        base = match.group(0)
        with urllib.request.urlopen(base) as response:
            assert response.read() == (exported / INDEX).read_bytes()
        with urllib.request.urlopen(base + RECORDING) as response:
            assert response.read() == (exported / RECORDING).read_bytes()
        # A link made after the server started, pointing outside the folder, is not followed.
        outside = exported.parent / "secret.txt"
        outside.write_text("not for the browser")
        (exported / "leak.txt").symlink_to(outside)
        try:
            with pytest.raises(urllib.error.HTTPError) as refused:
                urllib.request.urlopen(base + "leak.txt")
            assert refused.value.code == 404
            with pytest.raises(urllib.error.HTTPError):
                urllib.request.urlopen(base + "../secret.txt")
        finally:
            (exported / "leak.txt").unlink()
    finally:
        server.terminate()
        server.wait()


def test_replay_open_refuses_a_folder_without_index(tmp_path: Path):
    (tmp_path / "recording.viser").write_bytes(b"x")
    result = run("replay", "open", str(tmp_path), "--port", "0")
    assert result.returncode == 1
    assert "no index.html" in result.stderr and len(result.stderr.strip().splitlines()) == 1


def test_replay_open_refuses_links_pointing_outside(tmp_path: Path):
    folder = tmp_path / "replay"
    folder.mkdir()
    (folder / INDEX).write_text("<p>hi</p>")
    (folder / "passwd").symlink_to("/etc/passwd")
    result = run("replay", "open", str(folder), "--port", "0")
    assert result.returncode == 1
    assert "links outside the replay folder" in result.stderr


def test_replay_export_refuses_a_folder_of_other_files(tmp_path: Path):
    (tmp_path / "thesis.tex").write_text("precious")
    result = run("replay", "export", "--motion", "com_shift", "--out", str(tmp_path))
    assert result.returncode == 1
    assert "holding files this export did not write" in result.stderr
    assert (tmp_path / "thesis.tex").read_text() == "precious"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["thesis.tex"]
