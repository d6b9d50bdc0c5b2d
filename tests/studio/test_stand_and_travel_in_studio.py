"""The Simulation panel before and after a run: the stand check (can the robot stand on its
servos, before any motion, computed off the UI thread) and, for a walk, how far it went, where
its feet landed (3D markers) and the lifted-foot load plot."""

from __future__ import annotations

import math
import re
import threading

import numpy as np
import pinocchio as pin
import pytest

from app.core.posing.ready_pose import ready_pose
from app.core.simulation.verdicts import LEAN_LOAD_FRACTION
from app.studio.stand_checker import CHECKING
from tests.studio.conftest import GUARD_S, compute_torques, simulate, wait_for_signal


def stand_line(studio, accept=lambda _text: True) -> str:
    """The stand check's line once it is computed (and `accept`ed)."""
    session = studio.servo_rooms.simulation
    got: list[str] = []
    done = threading.Event()

    def receive(text: str) -> None:
        if accept(text):
            got.append(text)
            done.set()

    disconnect = session.stand.checked.connect(receive)
    try:
        shown = session.panel.stand.content
        if shown != CHECKING and accept(shown):
            return shown
        assert done.wait(GUARD_S), "no stand check"
        return got[0]
    finally:
        disconnect()


def _needs(text: str) -> float:
    match = re.search(r"needs ≤ ([0-9.]+) °/\(N·m\) at the ankles", text)
    assert match, text
    return float(match.group(1))


def _ankle_bound_deg_per_Nm(robot) -> float:
    """The textbook balance with rigid knees and hips: two ankle springs 1/c against m·g·h,
    h the CoM's height above the ankle pitch joints at the ready pose (pinocchio)."""
    q = ready_pose(robot).q
    data = robot.model.createData()
    com = pin.centerOfMass(robot.model, data, q)
    ankle = np.mean(
        [
            data.oMi[robot.model.getJointId(f"{side}_ankle_pitch")].translation[2]
            for side in ("left", "right")
        ]
    )
    return math.degrees(2.0 / (robot.mass_kg * 9.81 * (com[2] - ankle)))


def test_the_panel_says_before_any_motion_whether_the_robot_can_stand(studio):
    """servo_biped on its (paper) servos stands; the ankle limit shown lies under the rigid-
    knee textbook bound. Two ankle pitch servos made soft (typed into the panel) make it say
    it cannot stand, with the same limit; stiffened again, it stands."""
    first = stand_line(studio)
    assert first.startswith("✅") and "stands" in first, first
    limit = _needs(first)
    assert 1.4 < limit < _ankle_bound_deg_per_Nm(studio.state.robot)
    panel = studio.servo_rooms.compensation.panel

    def soften(value: float) -> None:
        for joint in ("left_ankle_pitch", "right_ankle_pitch"):
            panel.joint.value = joint
            panel.compliance.value = value

    soft = wait_for_signal(
        studio.servo_rooms.simulation.stand.checked,
        lambda: soften(20.0),
        lambda t: "cannot stand" in t,
    )
    assert soft.startswith("⚠️") and studio.servo_rooms.simulation.panel.stand.content == soft
    assert _needs(soft) == pytest.approx(limit, rel=0.02)  # the others unchanged
    back = wait_for_signal(
        studio.servo_rooms.simulation.stand.checked,
        lambda: soften(1.4),
        lambda t: t.startswith("✅"),
    )
    assert _needs(back) == pytest.approx(limit, rel=1e-3)


def test_a_robot_the_check_does_not_fit_is_told_so(tmp_path):
    """dircon_biped's legs have five joints: the line says the check does not apply."""
    from app.config import StudioConfig
    from app.studio import Studio
    from tests.studio.conftest import free_port

    studio = Studio(
        StudioConfig(port=free_port(), data_dir=tmp_path / "data", robot="dircon_biped")
    )
    try:
        text = stand_line(studio)
        assert text.startswith("**Stand check**: not for dircon_biped") and "six" in text
    finally:
        studio.stop()


def test_a_simulated_walk_says_how_far_it_went_and_marks_its_landings(studio):
    """Four 4 cm steps forward: the panel says how far each run walked and how far its
    footsteps landed from the plan's; the 3D view gets a marker per planned and simulated
    landing; the lifted-foot plot shows each run's load on the foot the plan has in the air
    (independently: the floor force of the run over the weight) against the 5 % line."""
    motions = studio.motions.panel
    motions.motion.value = "step_in_place"
    motions.inputs["steps"].value = 2
    motions.inputs["stride_m"].value = 0.04
    motions.generate.value = True
    compute_torques(studio)
    session = studio.servo_rooms.simulation
    ended = simulate(studio)
    assert ended.error == ""
    text = session.panel.verdict.content
    robot, trajectory = studio.state.robot, studio.state.trajectory
    planned = float(np.linalg.norm(trajectory.q[-1, :2] - trajectory.q[0, :2]))
    steps, lines = 0, 0
    for label, run in ended.results.items():
        travel = run.outcome.travel
        assert travel is not None and travel.distance_planned_m == pytest.approx(planned)
        assert f"{label}: walked **{travel.distance_covered_m:.2f} of {planned:.2f} m" in text
        steps += len(travel.footsteps)
        lines += bool(travel.footsteps)
    ghosts = studio.servo_rooms.ghosts
    assert ghosts.landings is not None
    # one white marker per planned landing, one per simulated landing, a line set per run
    # with landings (a run that falls early may land none)
    planned_landings = {
        s.planned_xy_m for r in ended.results.values() for s in r.outcome.travel.footsteps
    }
    assert ghosts.landings.count == len(planned_landings) + steps + lines
    ghosts.panel.landings.value = False
    ghosts.panel.landings.value = True
    lifted = ghosts.plots.lifted
    assert lifted is not None
    t, without, with_, threshold = lifted.data[0], lifted.data[1], lifted.data[2], lifted.data[3]
    assert np.all(threshold == 100 * LEAN_LOAD_FRACTION)
    run = ended.results["without compensation"]
    load = run.contact_force_N[:, :, 2] / (robot.mass_kg * 9.81)
    expected = 100 * np.where(trajectory.contacts, 0.0, load).max(axis=1)
    assert np.max(without) == pytest.approx(np.max(expected))
    assert len(t) == len(without) == len(with_)
    # a new motion drops the landings and the plot
    motions.motion.value = "com_shift"
    motions.generate.value = True
    assert ghosts.landings is None


def test_the_papers_43_mm_stand_leans_without_compensation_in_the_panel(studio):
    """The one-leg stand at the paper's 4.3 cm shift on servo_biped's servos: without
    compensation the lifted foot comes down (the paper's fall), with eq 7 it stays up; the
    plot's title says when."""
    motions = studio.motions.panel
    motions.motion.value = "one_leg_stand"
    motions.inputs["shift_m"].value = 0.043
    motions.generate.value = True
    compute_torques(studio)
    session = studio.servo_rooms.simulation
    ended = simulate(studio)
    text = session.panel.verdict.content
    assert "without compensation: **leans on the lifted foot" in text
    assert "with compensation: **stays up" in text
    lean = ended.results["without compensation"].outcome.lean
    assert (
        f"no comp. leans from {lean.start_s:.2f} s" in studio.servo_rooms.ghosts.plots.lifted.title
    )
    assert "walked" not in text  # a one-leg stand does not travel
