"""Opening project after project in a studio that prepares its sweep workers (what `serve`
does) logs no traceback (issue 24, item 9: 40 `FutureCancelledError` tracebacks over 50
opens): one preparer runs at a time, the robots loaded meanwhile fold into one more round for
the robot loaded last, and an interrupted preparation is quiet. The autouse fixture of
tests/conftest.py fails this test on any logged traceback."""

from __future__ import annotations

import threading
import time

from app.config import StudioConfig
from app.core.projects.files import project_bytes
from app.core.projects.project import Project
from app.core.projects.robot_files import robot_source
from app.core.robot.loading import load_robot
from app.studio import Studio
from tests.studio.conftest import GUARD_S, free_port

OPENS = 16


def _preparers() -> int:
    return sum(thread.name == "sweep-prepare" for thread in threading.enumerate())


def test_many_project_opens_prepare_quietly_for_the_last_robot(tmp_path):
    files = {
        name: project_bytes(Project(robot=robot_source(robot), q=robot.q_neutral))
        for name in ("servo_biped", "dircon_biped")
        for robot in (load_robot(name),)
    }
    config = StudioConfig(
        port=free_port(), data_dir=tmp_path / "data", prepare_sweep=True, autosave=False
    )
    studio = Studio(config)
    try:
        most = 0
        names = [("servo_biped", "dircon_biped")[i % 2] for i in range(OPENS)]
        for name in names:
            assert studio.project.open_upload(f"{name}.bstudio", files[name])
            most = max(most, _preparers())
        assert most <= 1  # never two preparers at once
        last = names[-1]
        done = threading.Event()

        def prepared(_costs: object) -> None:
            if f"with {last}'s" in studio.sweep.panel.status.content:
                done.set()

        disconnect = studio.sweep.workers.on_prepared.connect(prepared)
        try:
            prepared(None)  # it may already be prepared for the last robot
            assert done.wait(GUARD_S), studio.sweep.panel.status.content
        finally:
            disconnect()
    finally:
        studio.stop()


def test_a_robot_the_planner_cannot_walk_is_not_prepared_and_logs_one_line(tmp_path, caplog):
    """hybrid_leg_biped (its gait defaults admit no walk: sweep_choices) loaded in a studio that
    prepares its workers: the preparer says in one info line that it did not prepare, with no
    traceback (the autouse fixture), instead of logging the StudioError as a failure."""
    config = StudioConfig(
        port=free_port(), data_dir=tmp_path / "data", prepare_sweep=True, autosave=False
    )
    studio = Studio(config)
    try:
        with caplog.at_level("INFO", logger="app.studio.sweep_workers"):
            studio.robots.load("hybrid_leg_biped")
            deadline = time.monotonic() + GUARD_S
            said = []
            while not said and time.monotonic() < deadline:
                said = [r for r in caplog.records if "not prepared" in r.getMessage()]
                time.sleep(0.2)
        assert said, "the preparer never said it did not prepare"
        assert "cannot walk it" in said[0].getMessage()
        assert said[0].exc_info is None
    finally:
        studio.stop()
