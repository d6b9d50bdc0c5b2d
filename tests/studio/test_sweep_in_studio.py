"""The Sweep panel driven through its handles on a real studio: a small sweep on a real Dask
cluster fills the Pareto plot, bad input is refused keeping the state, and a picked point loads
its robot variant and a walk of its gait."""

from __future__ import annotations

import threading
from pathlib import Path

import numpy as np
import pytest

from app.core.projects.files import read_project
from app.core.projects.robot_files import load_project_robot
from app.core.sweeps.pareto import pareto_mask
from tests.studio.conftest import GUARD_S, load_point, run_sweep, set_sweep, wait_for_signal


def test_sweep_panel_runs_plots_and_loads_a_point(studio):
    session, panel = studio.sweep, studio.sweep.panel
    assert studio.robots.load("dircon_biped")  # the panel sweeps the loaded robot
    robot_before = studio.state.robot

    # bad input: a range the planner refuses; nothing starts, the robot stays
    panel.param_a.value = "gait:step_length_m"
    panel.min_a.value, panel.max_a.value = 0.1, 3.0
    session.run(None)
    assert "leaves what the planner accepts" in panel.status.content
    assert session.outcome is None and studio.state.robot is robot_before

    set_sweep(
        panel,
        ("gait:step_length_m", 0.14, 0.26),
        ("robot:thigh_length_m", 0.37, 0.41),
        samples=3,
        workers=2,
    )
    panel.metric_x.value, panel.metric_y.value = "sr", "max_torque_Nm"
    outcome = run_sweep(studio)
    assert not outcome.error and not outcome.cancelled
    assert len(outcome.results) == 3
    solved = [r for r in outcome.results if r.solved]
    assert solved, [r.reason for r in outcome.results]
    for r in outcome.results:
        assert 0.14 <= r.values[0] <= 0.26 and 0.37 <= r.values[1] <= 0.41
    # the front shown is the Pareto set of the solved points' two metrics
    xy = np.array([[r.sr, r.max_torque_Nm] for r in solved])
    expected = {
        r.index for r, on in zip(solved, pareto_mask(xy, ["min", "min"]), strict=True) if on
    }
    assert set(outcome.pareto) == expected
    assert panel.plot is not None
    x, designs, fell, front, failed = panel.plot.data
    assert not np.isfinite(fell).any()  # no simulation: no point fell
    assert np.count_nonzero(np.isfinite(failed)) == 3 - len(solved)
    drawn = np.isfinite(designs)
    assert sorted(x[drawn]) == sorted(xy[:, 0]) and sorted(designs[drawn]) == sorted(xy[:, 1])
    assert np.count_nonzero(np.isfinite(front)) == len(expected)
    counts = f"3 / 3 done: {len(solved)} solved, {3 - len(solved)} failed, 0 cancelled"
    assert counts in panel.status.content

    # an unsolved or unknown point is refused with the reason
    panel.point.value = 99
    session.load_point(None)
    assert "point 99 has no gait" in panel.status.content

    best = outcome.pareto[0]
    assert load_point(studio, best) == best
    robot = studio.state.robot
    assert robot is not robot_before and robot.name == "dircon_biped"
    point = session.points[best]
    ((name, thigh),) = point.robot.values
    knee = robot.model.getJointId("left_knee")
    assert name == "thigh_length_m"
    assert -robot.model.jointPlacements[knee].translation[2] == pytest.approx(thigh)
    motion = studio.state.motion
    assert motion is not None and f"sweep point #{best}" in motion.summary
    assert motion.trajectory.duration > 0
    # The design's URDF stays where the studio keeps it (the gait worker and project saves
    # read the robot's source again), and a saved project opens it in a fresh load.
    assert Path(robot.source).is_file()
    assert studio.project.save_as("design"), studio.project.last_error
    saved = studio.project.path
    reopened = load_project_robot(read_project(saved).robot, studio.config.uploads_dir)
    assert reopened.model.jointPlacements[knee].translation[2] == pytest.approx(-thigh)

    # Cancel: a larger sweep stops after its first result; the loaded design stays
    panel.samples.value = 12
    done = threading.Event()
    ends: list = []
    disconnect = session.on_sweep_done.connect(lambda o: (ends.append(o), done.set()))
    try:
        wait_for_signal(session.on_result, lambda: setattr(panel.run_button, "value", True))
        panel.cancel_button.value = True
        assert done.wait(GUARD_S)
    finally:
        disconnect()
    assert ends[0].cancelled and len(ends[0].results) < 12
    back = ends[0].results
    solved_back = sum(r.solved for r in back)
    assert (
        f"12 / 12 done: {solved_back} solved, {len(back) - solved_back} failed, "
        f"{12 - len(back)} cancelled"
    ) in panel.status.content
    assert "Sweep cancelled" in panel.status.content and not panel.run_button.disabled
    assert studio.state.robot is robot


def test_a_sweep_cancelled_before_its_first_result_says_so_in_words(studio):
    """Cancel at once: the status ends on the cancel's line alone, not below a stale
    "Starting … points…", and names no Pareto point as a Python list."""
    session, panel = studio.sweep, studio.sweep.panel
    set_sweep(panel, ("gait:step_length_m", 0.1, 0.2), samples=40)
    done = threading.Event()
    ends: list = []
    disconnect = session.on_sweep_done.connect(lambda o: (ends.append(o), done.set()))
    try:
        panel.run_button.value = True
        panel.cancel_button.value = True
        assert done.wait(GUARD_S)
    finally:
        disconnect()
    assert ends[0].cancelled
    assert not ends[0].results, "a result came before the Cancel: this test needs none"
    status = panel.status.content
    assert status.startswith("Sweep cancelled: 40 / 40 done: 0 solved, 0 failed, 40 cancelled")
    assert "Starting" not in status and "[" not in status
    assert "Pareto points: none." in status
