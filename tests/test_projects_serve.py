"""A real `biped-studio serve` process killed with SIGKILL comes back with the work it had:
autosave is on disk before the kill, and the next start restores it (unless --fresh)."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from app.core.motions.keyframes import capture_keyframe
from app.core.motions.library import run_motion
from app.core.projects.files import read_project, save_project
from app.core.projects.project import Project
from app.core.projects.robot_files import robot_source
from app.core.robot.loading import load_robot
from tests.same_values import assert_same

ROOT = Path(__file__).resolve().parents[1]
GUARD_S = 300.0
"""A wait longer than this fails the test instead of hanging the suite."""


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@contextmanager
def serve(data: Path, *args: str) -> Iterator[subprocess.Popen]:
    """`python -m app serve` on a free port with its data in `data`; killed at the end."""
    env = {**os.environ, "BIPED_STUDIO_DATA": str(data)}
    process = subprocess.Popen(
        [sys.executable, "-m", "app", "serve", "--port", str(_free_port()), "--no-token", *args],
        cwd=ROOT,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    try:
        yield process
    finally:
        if process.poll() is None:
            process.kill()
        process.wait()


def lines_until_ready(process: subprocess.Popen) -> list[str]:
    """stdout lines up to the one with the studio's link (the studio is then serving)."""
    assert process.stdout is not None
    lines = []
    for line in process.stdout:  # blocks until the process writes: no sleeps
        lines.append(line.rstrip())
        if line.strip().startswith("http://"):
            return lines
    raise AssertionError(f"serve exited before serving: {lines}")


def wait_for_file(folder: Path, process: subprocess.Popen) -> Path:
    """The first file to appear in `folder` while `process` runs (polled: another process)."""
    deadline = time.monotonic() + GUARD_S
    while time.monotonic() < deadline:
        files = sorted(folder.glob("autosave-*.bstudio")) if folder.is_dir() else []
        if files:
            return files[-1]
        assert process.poll() is None, "serve exited"
        time.sleep(0.05)
    raise AssertionError(f"no autosave appeared in {folder}")


def test_sigkill_then_restart_restores_the_work(tmp_path):
    robot = load_robot("servo_biped")
    motion = run_motion(robot, "com_shift").trajectory
    work = Project(
        robot=robot_source(robot),
        q=motion.q[60].copy(),
        keyframes=(capture_keyframe(robot, motion.q[30], "both", "lean", 0.9),),
        motion=motion,
        motion_summary="com_shift",
        time_s=0.6,
    )
    project = tmp_path / "work.bstudio"
    save_project(project, work)
    data = tmp_path / "data"

    with serve(data, "--project", str(project)) as first:
        assert any("servo_biped" in line for line in lines_until_ready(first))
        autosave = wait_for_file(data / "autosave", first)
        first.send_signal(signal.SIGKILL)
        assert first.wait() == -signal.SIGKILL
    saved = read_project(autosave)  # whole: written to a temporary file, then renamed
    for field in ("q", "keyframes", "motion", "time_s"):
        assert_same(getattr(saved, field), getattr(work, field), field)

    with serve(data) as second:
        lines = lines_until_ready(second)
    restored = [line for line in lines if line.startswith("Restored your work from")]
    assert restored, lines
    assert "servo_biped, motion com_shift at 0.60 s, 1 keyframe(s)" in restored[0]

    with serve(data, "--fresh") as third:
        lines = lines_until_ready(third)
    assert not any("Restored" in line for line in lines)
