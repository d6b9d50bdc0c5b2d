"""A simulation whose worker process dies (killed, out of memory) tells the user what to do
next in the words of the button they press: Simulate, not the gait panel's Solve (issue 24,
item 9)."""

from __future__ import annotations

import re
import threading
from pathlib import Path

import psutil

from app.core.motions.library import run_motion
from app.core.robot.loading import load_robot
from app.core.servo.model import joint_angles
from app.core.simulation.files import default_servos
from app.studio.simulation_runner import SimulationRunner

PANEL = Path(__file__).resolve().parents[2] / "panels" / "simulation_panel.py"
GUARD_S = 300.0


def _spawned_workers() -> list[psutil.Process]:
    return [
        child
        for child in psutil.Process().children(recursive=True)
        if "multiprocessing.spawn" in " ".join(child.cmdline())
        and "resource_tracker" not in " ".join(child.cmdline())
    ]


def test_a_killed_simulation_worker_says_to_press_simulate_again():
    robot = load_robot("servo_biped")
    trajectory = run_motion(robot, "com_shift").trajectory
    q_plan = joint_angles(robot, trajectory.q)
    before = {p.pid for p in _spawned_workers()}
    progressed, ended = threading.Event(), threading.Event()
    runner = SimulationRunner(on_progress=lambda _fraction: progressed.set())
    outcome: list = []
    runner.finished.connect(lambda simulation: (outcome.append(simulation), ended.set()))
    try:
        runner.start(robot, trajectory, q_plan, q_plan, default_servos(robot))
        assert progressed.wait(GUARD_S), "the simulation never reported progress"
        (worker,) = [p for p in _spawned_workers() if p.pid not in before]
        worker.kill()
        assert ended.wait(GUARD_S), "the crash was never reported"
    finally:
        runner.close()
    error = outcome[0].error
    assert error.startswith("the solver process crashed (exit code -9, SIGKILL)"), error
    assert "Solve" not in error
    button = re.search(r"press (.+) again$", error)
    assert button is not None, error
    assert f'"{button[1]}"' in PANEL.read_text()  # the label of a real button
