"""The Sweep panel sweeps the robot the studio has loaded, on a real studio and Dask cluster: a
gait sweep on servo_biped equals the same points evaluated one by one through app.core, and
loading another robot offers that robot's choices (a URDF file: no robot parameters) and
cancels the sweep under way."""

from __future__ import annotations

import shutil
import threading

from app.core.sweeps.robot_variants import ROBOT_PARAMETERS
from robots.catalogue import BUILTIN_ROBOTS
from tests.studio.conftest import (
    GUARD_S,
    assert_points_match_core,
    load_point,
    run_sweep,
    set_sweep,
    wait_for_signal,
)

STEP = (0.05, 0.07)
"""Step lengths [m] around servo_biped's 0.7 m legs' natural advance (not the panel's)."""
SAME = {
    "robot": "servo_biped",
    "sampling": "latin",
    "samples": 2,
    "seed": 0,
    "gait": {"knots": 14},
    "pareto": {"sr": "min", "max_torque_Nm": "min"},
    "parameter": [{"kind": "gait", "name": "step_length_m", "min": STEP[0], "max": STEP[1]}],
}
"""The sweep the panel is set to below, written out for app.core."""
METRICS = ("sr", "sr_incl_impacts", "max_torque_Nm", "max_joint_speed_radps", "energy_J")


def test_a_gait_sweep_of_servo_biped_matches_core_point_by_point(studio):
    panel = studio.sweep.panel
    assert studio.state.robot.name == "servo_biped"
    assert "**servo_biped**" in panel.robot_line.content
    set_sweep(panel, ("gait:step_length_m", *STEP), samples=2)
    panel.metric_x.value, panel.metric_y.value = "sr", "max_torque_Nm"
    outcome = run_sweep(studio)
    assert not outcome.error and outcome.spec.robot == "servo_biped"
    by_panel = sorted(outcome.results, key=lambda r: r.index)
    assert any(r.solved for r in by_panel), [r.reason for r in by_panel]

    # the same points evaluated here through app.core, on servo_biped's own planner defaults
    for point in assert_points_match_core(by_panel, SAME, METRICS):
        assert point.robot.robot == "servo_biped" and not point.robot.values
        assert STEP[0] <= point.values[0] <= STEP[1]

    # Load point of a gait sweep: the robot on screen stays, and so do the panel's choices
    robot = studio.state.robot
    best = next(r for r in by_panel if r.solved)
    assert load_point(studio, best.index) == best.index and studio.state.robot is robot
    assert f"sweep point #{best.index}" in studio.state.motion.summary
    assert (panel.param_a.value, panel.min_a.value, panel.max_a.value) == (
        "gait:step_length_m",
        *STEP,
    )


def test_loading_another_robot_offers_its_choices_and_cancels_the_sweep(studio, tmp_path):
    session, panel = studio.sweep, studio.sweep.panel
    servo_only = "robot:torque_limit_Nm"  # servo_biped has it, dircon_biped does not
    assert servo_only in panel.param_c.options
    panel.param_c.value = servo_only
    panel.param_a.value = "gait:K0"
    panel.samples.value, panel.workers.value = 12, 1

    # a sweep under way on servo_biped is cancelled by loading dircon_biped
    done = threading.Event()
    ends: list = []
    disconnect = session.on_sweep_done.connect(lambda o: (ends.append(o), done.set()))
    try:
        panel.run_button.value = True
        offered = wait_for_signal(session.on_choices, lambda: studio.robots.load("dircon_biped"))
        assert done.wait(GUARD_S)
    finally:
        disconnect()
    assert offered == "dircon_biped" and ends[0].cancelled and ends[0].spec.robot == "servo_biped"
    assert len(ends[0].results) < 12
    assert "the robot changed to dircon_biped" in panel.status.content

    dircon = ROBOT_PARAMETERS["dircon_biped"]
    assert "**dircon_biped**" in panel.robot_line.content
    assert servo_only not in panel.param_c.options and panel.param_c.value == "(none)"
    assert panel.param_a.value == "gait:step_length_m"  # the first choices again
    robot_options = {o for o in panel.param_a.options if o.startswith("robot:")}
    assert robot_options == {f"robot:{name}" for name in dircon}
    panel.param_b.value = "robot:thigh_length_m"
    thigh = dircon["thigh_length_m"]
    assert (panel.min_b.value, panel.max_b.value) == (thigh.minimum, thigh.maximum)

    # a URDF file (not a built-in's): gait, servo and part parameters only, the reason said
    copy = tmp_path / "my_biped.urdf"
    shutil.copy(BUILTIN_ROBOTS["servo_biped"].urdf_path, copy)
    offered = wait_for_signal(session.on_choices, lambda: studio.robots.load(copy))
    assert offered == str(copy)
    assert not any(o.startswith("robot:") for o in panel.param_a.options)
    assert "no robot parameters" in panel.robot_line.content
    assert {o.split(":")[0] for o in panel.param_a.options} == {"gait", "servo", "part"}

    # its sweep runs on the file, and Load point keeps that robot and plays the point's gait
    robot = studio.state.robot
    set_sweep(panel, ("gait:H_s", 0.53, 0.57), samples=1)  # converges on servo_biped's legs
    outcome = run_sweep(studio)
    assert outcome.spec.robot == str(copy) and not outcome.error
    # the workers load the file as the studio did: its feet, the studio's package folders
    assert outcome.spec.feet == (robot.foot("left").link, robot.foot("right").link)
    assert outcome.spec.package_roots == tuple(str(p) for p in studio.config.package_roots)
    (result,) = outcome.results
    assert result.solved, result.reason
    assert load_point(studio, result.index) == 0
    assert studio.state.robot is robot
    assert f"sweep point #{result.index}" in studio.state.motion.summary
