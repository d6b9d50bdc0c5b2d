"""Torque feed-forward and compensation through the studio's panels: a real viser server."""

from __future__ import annotations

import csv
import dataclasses
import io
import re

import numpy as np
import pytest

from app.core.simulation.mjcf import SimOptions
from app.core.simulation.on_plan import on_plan_stance
from panels.compensation_panel import COMPENSATED_TORQUE_LABELS
from tests.studio.conftest import (
    compute_torques,
    simulate,
    start_studio,
    wait_for_signal,
    with_stand_torques,
)


def assert_ghost_at(ghosts, name, q):
    """The ghost is drawn, each of its meshes where the robot at q has it (pinocchio)."""
    robot = ghosts.robot
    placements = robot.link_placements(q, robot.model.createData())
    positions, _ = ghosts.mesh_poses(name)
    visuals = [mesh for mesh in robot.meshes if mesh.role != "collision"]
    expected = [(placements[mesh.link] @ mesh.T_link_mesh)[:3, 3] for mesh in visuals]
    assert ghosts.shown(name)
    np.testing.assert_allclose(positions, expected, atol=1e-9)


@pytest.fixture
def studio(studio):
    """The conftest's studio with the one-leg stand and its torques (each test its own)."""
    return with_stand_torques(studio)


def test_torques_plots_and_ghosts_follow_the_motion(studio):
    session = studio.servo_rooms.ghosts
    feedforward, prediction = studio.state.work.torques, studio.state.work.prediction
    assert feedforward is not None and prediction is not None
    assert feedforward.tau_Nm.shape == (
        studio.state.trajectory.n_samples,
        studio.state.robot.n_actuated,
    )
    assert session.plots.torques is not None and session.plots.attitude is not None
    # time, one curve per joint, the time cursor
    assert len(session.plots.torques.data) == 2 + studio.state.robot.n_actuated
    # By default the plan and one comparison (the command); the compensated quick estimate
    # is ticked here, and stands where the prediction says at the shown sample.
    assert {name for name, box in session.panel.ghosts.items() if box.value} == {
        "planned",
        "command",
    }
    session.panel.ghosts["with"].value = True
    studio.playback.seek(3.0)
    k = studio.state.trajectory.index_at(3.0)
    assert_ghost_at(session.view, "with", prediction.q_world_compensated[k])


def test_the_plots_time_cursor_follows_the_timeline(studio):
    """A seek moves every plot's cursor: a vertical line at the sample shown, over curves that
    keep the prediction's torques."""
    session = studio.servo_rooms.ghosts
    seek_to = float(studio.state.trajectory.t[studio.state.trajectory.index_at(3.0)])
    wait_for_signal(
        session.cursor_shown, lambda: studio.playback.seek(seek_to), accept=lambda t: t == seek_to
    )
    assert studio.state.time_s == seek_to
    for plot in (session.plots.torques, session.plots.roll, session.plots.pitch):
        x, *curves, cursor = plot.data
        above = np.flatnonzero(cursor > 1.0)  # the cursor's scale is [0, 1]
        assert len(above) == 1 and x[above[0]] == seek_to
        assert np.all(np.delete(cursor, above) < 0.0)
    x, *curves, cursor = session.plots.torques.data
    # Without the three cursor samples, the torque curves are the prediction's, at its times.
    keep = np.ones(len(x), bool)
    keep[np.flatnonzero(cursor > 1.0)[0] + np.array([-1, 0, 1])] = False
    prediction = studio.state.work.prediction
    k = np.searchsorted(prediction.t, x[keep])
    np.testing.assert_array_equal(prediction.t[k], x[keep])
    np.testing.assert_array_equal(np.array(curves)[:, keep], prediction.tau_Nm[k].T)
    # Picking one joint keeps the cursor where it is.
    session.plots.joints.value = studio.state.robot.joint_names[2]
    x, _curve, cursor = session.plots.torques.data
    assert x[np.argmax(cursor)] == seek_to


def test_wide_plots_move_every_plot_into_a_window_and_back(studio):
    plots = studio.servo_rooms.ghosts.plots
    before = {key: getattr(plots, key) for key in ("torques", "roll", "pitch", "offsets")}
    plots.wide.value = True
    assert plots.window is not None
    for key, old in before.items():
        new = getattr(plots, key)
        assert new is not old and new.aspect > old.aspect  # a new, wider plot in the window
        assert len(new.data) == len(old.data)
        for a, b in zip(new.data, old.data, strict=True):
            np.testing.assert_array_equal(a, b)
    # Edits and the cursor reach the plots where they are now.
    studio.playback.seek(1.0)
    plots.show_time(1.0)
    x, *_curves, cursor = plots.torques.data
    assert x[np.argmax(cursor)] == 1.0
    plots.wide.value = False
    assert plots.window is None and plots.torques.aspect == before["torques"].aspect


def test_compensation_reduces_the_torso_error(studio):
    errors = studio.state.work.prediction.attitude_errors_deg()
    worst_without = max(errors["roll_uncompensated"], errors["pitch_uncompensated"])
    worst_with = max(errors["roll_compensated"], errors["pitch_compensated"])
    assert worst_without > 0.05  # the compliant servos make the torso tilt
    assert worst_with < 0.5 * worst_without


def test_a_k_slider_changes_the_command_by_k_tau_without_recomputing_torques(studio):
    state, panel = studio.state, studio.servo_rooms.compensation.panel
    feedforward = state.work.torques
    panel.joint.value = "left_hip_roll"
    i = studio.state.robot.joint_names.index("left_hip_roll")
    before = state.work.prediction.q_cmd_rad[:, i].copy()
    k_before = state.work.coefficients.params.k_deg_per_Nm[i]
    panel.enabled.value = True
    panel.k.value = k_before + 10.0
    after = state.work.prediction.q_cmd_rad[:, i]
    # eq 7 on the drive torque τ + D·q̇ + J·q̈ (the default): D = τ_max/ω_max of the joint's
    # URDF limits, J the simulation's armature
    joint, motion = studio.state.robot.joints[i], state.trajectory
    damping, rotor = joint.effort / joint.velocity, SimOptions().armature_kgm2
    tau = feedforward.tau_Nm[:, i]
    drive = tau + damping * motion.v[:, joint.idx_v] + rotor * motion.a[:, joint.idx_v]
    np.testing.assert_allclose(after - before, np.deg2rad(10.0) * drive, atol=1e-12)
    # on the load torque, eq 7 as printed
    panel.compensate.value = COMPENSATED_TORQUE_LABELS["load"]
    load = state.work.prediction.q_cmd_rad[:, i].copy()
    panel.k.value = k_before + 20.0
    np.testing.assert_allclose(
        state.work.prediction.q_cmd_rad[:, i] - load, np.deg2rad(10.0) * tau, atol=1e-12
    )
    # and back on the drive torque (the session keeps one compensated torque: not the stale one)
    panel.compensate.value = COMPENSATED_TORQUE_LABELS["drive"]
    on_drive = state.work.prediction.q_cmd_rad[:, i].copy()
    panel.k.value = k_before + 30.0
    np.testing.assert_allclose(
        state.work.prediction.q_cmd_rad[:, i] - on_drive, np.deg2rad(10.0) * drive, atol=1e-12
    )
    assert state.work.torques is feedforward
    assert "rad/(N·m)" in panel.k_rad.content


def test_export_servo_commands(studio):
    content = studio.servo_rooms.compensation.export_commands()
    rows = list(csv.reader(io.StringIO(content.decode())))
    header = rows[0]
    assert (
        header[0] == "t [s]"
        and "q_cmd:left_knee [rad]" in header
        and "q_cmd:left_knee [deg]" in header
    )
    assert len(rows) == 1 + studio.state.trajectory.n_samples
    rad = float(rows[5][header.index("q_cmd:left_knee [rad]")])
    deg = float(rows[5][header.index("q_cmd:left_knee [deg]")])
    assert deg == pytest.approx(np.rad2deg(rad))
    torques = studio.servo_rooms.torques.export_torques()
    assert torques.decode().splitlines()[0].startswith("t [s],tau:")


def test_a_new_motion_drops_the_stale_torques(studio):
    studio.motions.panel.motion.value = "com_shift"
    studio.motions.panel.generate.value = True
    assert studio.state.work.torques is None and studio.state.work.prediction is None
    result = compute_torques(studio)
    assert result is studio.state.work.torques
    assert studio.state.work.torques.trajectory_name == "com_shift"


def test_simulate_shows_a_verdict_ghosts_and_simulated_curves(studio):
    """Simulate from the panel: a real worker process runs MuJoCo; the verdict, two more
    ghosts (placed where the simulation has the robot) and the simulated roll/pitch curves."""
    session, ghosts = studio.servo_rooms.simulation, studio.servo_rooms.ghosts
    ended = simulate(studio)
    assert ended.error == "" and studio.state.work.simulation.run is ended
    without, with_ = ended.results["without compensation"], ended.results["with compensation"]
    for run in (without, with_):
        assert run.verdict() in session.panel.verdict.content
        assert run.q.shape == (studio.state.trajectory.n_samples, studio.state.robot.model.nq)
    assert "Simulated" in session.panel.verdict.content
    # Two more curves in each attitude plot: planned, two quick estimates, two simulations.
    assert len(ghosts.plots.roll.data) == 2 + 5 and len(ghosts.plots.pitch.data) == 2 + 5
    # The simulated ghost becomes the comparison; it stands where the simulation put the
    # robot at the shown sample, moved over the floor onto the plan's stance foot.
    robot = studio.state.robot
    assert ghosts.panel.ghosts["sim_with"].value and not ghosts.panel.ghosts["command"].value
    studio.playback.seek(1.0)
    trajectory = studio.state.trajectory
    k = trajectory.index_at(1.0)
    shift = on_plan_stance(robot, trajectory, with_.q).q[k] - with_.q[k]
    assert np.all(shift[2:] == 0.0) and np.linalg.norm(shift[:2]) < 0.05
    assert_ghost_at(ghosts.view, "sim_with", with_.q[k] + shift)
    assert robot is ghosts.view.robot
    # A coefficient change marks the simulation stale, and keeps it.
    k = studio.servo_rooms.compensation.panel.k
    k.value = float(k.value) + 0.5
    assert studio.state.work.simulation.stale and "Stale" in session.panel.verdict.content
    assert studio.state.work.simulation.run is ended


def test_simulate_needs_torques(tmp_path):
    studio = start_studio(tmp_path / "data")
    try:
        studio.servo_rooms.simulation.simulate()
        assert "compute the torque feed-forward first" in studio.notifier.last_error
        assert studio.servo_rooms.simulation.runner.running is None
    finally:
        studio.stop()


def test_compute_torques_runs_on_the_studios_pool_and_equals_the_serial_run(studio):
    """The studio's τ come from its warm worker pool (kept for the next click) and equal the
    in-process serial feed-forward to 1e-9 of the peak torque (as the CLI's check)."""
    from app.core.dynamics.wbc import torque_feedforward

    session = studio.servo_rooms.torques
    assert studio.state.trajectory.n_samples < session.pool_min_samples
    assert session.feedforward_pool is None  # too short to pay: solved in the thread
    in_thread = studio.state.work.torques
    session.pool_min_samples = 0  # this motion now goes to the pool
    assert compute_torques(studio) is not None
    pool = session.feedforward_pool
    assert pool is not None and pool.workers >= 1
    robot, trajectory = studio.state.robot, studio.state.trajectory
    serial = torque_feedforward(robot, trajectory)
    pooled = studio.state.work.torques
    assert pooled is not None
    peak = max(1.0, float(np.nanmax(np.abs(serial.tau_Nm))))
    assert np.nanmax(np.abs(pooled.tau_Nm - serial.tau_Nm)) <= 1e-9 * peak
    assert pooled.status == serial.status
    # The threshold picks the path, not the torques: the thread's run is the serial one.
    assert np.nanmax(np.abs(in_thread.tau_Nm - serial.tau_Nm)) <= 1e-9 * peak
    assert in_thread.status == serial.status
    # A second click reuses the same warm pool.
    again = compute_torques(studio)
    assert again is not None and session.feedforward_pool is pool


def test_the_feedforward_pool_closes_with_the_studio(tmp_path):
    studio = start_studio(tmp_path / "data")
    try:
        studio.motions.panel.motion.value = "one_leg_stand"
        studio.motions.panel.generate.value = True
        studio.servo_rooms.torques.pool_min_samples = 0
        assert compute_torques(studio) is not None
        assert studio.servo_rooms.torques.feedforward_pool is not None
    finally:
        studio.stop()
    assert studio.servo_rooms.torques.feedforward_pool is None


class DownloadingTab:
    """Stands for a tab: records the names of the files the studio sends it."""

    def __init__(self) -> None:
        self.names: list[str] = []

    def send_file_download(self, name: str, content: bytes, **_: object) -> None:
        self.names.append(name)


def test_the_files_of_a_motion_named_in_words_are_named_alike_without_spaces(studio):
    """A gait's walk is named "walk of 4 steps": its τ and servo-command CSVs must be named
    like its motion CSV (no spaces, nothing a shell or a path would split on)."""
    state = studio.state
    trajectory = dataclasses.replace(state.trajectory, name="walk of 4 steps / ../x")
    state.set_motion(trajectory, state.motion.summary, state.robot)
    compute_torques(studio)
    tab = DownloadingTab()
    studio.motions.export(tab)
    studio.servo_rooms.torques.export_torques(tab)
    studio.servo_rooms.compensation.export_commands(tab)
    motion_csv, tau_csv, commands_csv = tab.names
    stem = motion_csv.removesuffix(".csv")
    assert (tau_csv, commands_csv) == (f"{stem}_tau.csv", f"{stem}_servo_commands.csv")
    for name in tab.names:
        assert re.fullmatch(r"[A-Za-z0-9][A-Za-z0-9._-]*", name), name


def test_a_warning_of_the_quick_estimate_goes_once_it_no_longer_holds(studio):
    """Table 2 on the one-leg stand predicts a fall; "none" then commands the plan itself, the
    no-compensation estimate (which stands): the warning must not stay in the status."""
    session = studio.servo_rooms.compensation
    session.apply_preset("table2")
    assert "would fall" in session.panel.status.content
    session.apply_preset("none")
    params = studio.state.work.coefficients.params
    assert not np.any(params.k_deg_per_Nm[params.enabled])
    status = session.panel.status.content
    assert "would fall" not in status and "⚠️" not in status
    assert status.startswith("τ of **one_leg_stand**: max |τ|")
