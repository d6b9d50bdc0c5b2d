"""The gait planner from the studio's panel: a real worker process, a real IPOPT solve."""

from __future__ import annotations

import threading

import numpy as np

from app.core.papers import TABLE4
from tests.sole_frames import model_with_sole_edge_frames
from tests.studio.conftest import GUARD_S, one_click, solve_gait, wait_for_signal


def test_solve_for_the_loaded_robot_then_walk_it(studio):
    panel = studio.gait.panel
    robot = studio.state.robot
    assert robot.name == "servo_biped" and "servo_biped" in panel.robot_note.content
    ended = solve_gait(studio)
    result = studio.gait.results.symmetric
    assert ended.result is result and result.converged
    assert "Solved in" in panel.status.content
    assert "max \\|τ\\|" in panel.results.content
    assert f"{TABLE4.max_abs_tau_Nm[0]} / {TABLE4.max_abs_tau_Nm[1]}" in panel.results.content
    assert len(studio.gait.solves.history[0]) >= 1  # convergence was reported live
    # Step lengths within what the slack bounds allow: x1 = (0.5 + slack0)(x0 + x2).
    lsp, rsp = result.step_lengths_m
    assert abs(lsp - rsp) <= 2 * 0.05 * (lsp + rsp) + 1e-6
    panel.steps.value = 3
    panel.use.value = True
    trajectory = studio.state.trajectory
    assert studio.state.robot is robot and trajectory is not None
    assert trajectory.contacts[0].all() and trajectory.contacts[-1].all()  # standing to standing
    assert len(studio.gait.walk.footprints) == 3 + 2 and studio.gait.footprints is not None
    # The feet that stand do not slide (checked with pinocchio, not the planner).
    data = robot.model.createData()
    left = np.array(
        [robot.link_placements(q, data)[robot.feet[0].link][:3, 3] for q in trajectory.q]
    )
    standing = trajectory.contacts[:, 0]
    runs = np.split(np.arange(len(standing)), np.flatnonzero(np.diff(standing.astype(int))) + 1)
    for run in runs:
        if standing[run[0]] and len(run) > 1:
            assert np.ptp(left[run, :2], axis=0).max() < 2e-3
    # Another motion takes the footprints away.
    studio.motions.panel.generate.value = True
    assert studio.gait.footprints is None


def test_a_robot_the_planner_cannot_handle_says_why(studio):
    studio.robots.load("hybrid_leg_biped")
    panel = studio.gait.panel
    assert "cannot plan" in panel.robot_note.content
    assert panel.solve.disabled
    assert studio.gait.solve(baseline=False) is None


def test_changing_a_setting_marks_the_result_stale(studio):
    panel = studio.gait.panel
    solve_gait(studio)
    assert "stale" not in panel.results.content
    panel.sliders["K0"].value = 5.0
    assert "stale" in panel.results.content
    panel.sliders["K0"].value = 6.5
    assert "stale" not in panel.results.content


def test_a_crafted_knot_count_is_refused_before_the_worker_builds(studio):
    """A client can send values the slider would never allow (knots = 400)."""
    panel = studio.gait.panel
    panel.sliders["knots"]._impl.value = 400.0  # what a crafted websocket message sets
    assert studio.gait.solve(baseline=False) is None
    assert studio.gait.solves.running is None
    assert "knots" in panel.status.content and "160" in panel.status.content


def test_cancel_keeps_the_last_good_gait(studio):
    panel = studio.gait.panel
    solve_gait(studio)
    good = studio.gait.results.symmetric
    panel.sliders["knots"].value = 80  # a new structure: the worker builds a larger NLP first

    def solve_then_cancel() -> None:
        panel.solve.value = True
        panel.cancel.value = True

    ended = wait_for_signal(studio.gait.finished, solve_then_cancel)
    assert ended.error == "cancelled"
    assert studio.gait.solves.running is None
    assert "Cancelled" in panel.status.content
    assert studio.gait.results.symmetric is good


def test_one_click_plans_walks_computes_torques_and_simulates(studio):
    """Plan → walk → torques → compensation → simulation from one button: every stage's
    result stays inspectable, and each belongs to the walk just planned."""
    simulated = one_click(studio)
    assert studio.gait.results.symmetric is not None and studio.gait.walk is not None
    walk = studio.gait.walk.trajectory
    assert studio.state.trajectory is walk
    state = studio.state
    assert state.work.torques is not None
    assert state.work.torques.tau_Nm.shape == (walk.n_samples, studio.state.robot.n_actuated)
    assert state.work.prediction is not None
    assert simulated.error == "" and simulated.trajectory is walk
    assert state.work.simulation.run is simulated
    assert "Simulated" in studio.servo_rooms.simulation.panel.verdict.content


def test_the_loaded_robots_default_problem_is_built_ahead_of_the_first_solve(tmp_path):
    """With prepare_gait (what `serve` uses), loading a robot builds its default structure in
    the worker; the first solve of that structure then runs on that build."""
    from app.config import StudioConfig
    from app.studio import Studio
    from tests.studio.conftest import free_port

    studio = Studio(StudioConfig(port=free_port(), data_dir=tmp_path, prepare_gait=True))
    try:
        key = wait_for_signal(
            studio.gait.prepared,
            lambda: studio.robots.load("dircon_biped"),
            accept=lambda key: "dircon_biped" in key.robot,
        )
        assert key.knots == studio.gait.panel.settings(False).knots and not key.baseline
        ended = solve_gait(studio)
        assert ended.result is not None and ended.result.converged
    finally:
        studio.stop()


def test_a_running_solve_shows_in_the_shared_panel_and_is_never_replaced(studio):
    """Every tab draws the same panel: one opened during a solve sees its status, progress
    and Cancel; a Solve click from any tab meanwhile is refused (it used to cancel the running
    solve silently and take over its status)."""
    panel = studio.gait.panel
    ended: list = []
    done = threading.Event()
    disconnect = studio.gait.finished.connect(lambda solve: (ended.append(solve), done.set()))
    try:
        wait_for_signal(studio.gait.progressed, lambda: setattr(panel.solve, "value", True))
        running = studio.gait.solves.running
        assert running is not None and running.kind == "symmetric gait"
        assert f"Solving the symmetric gait (job {running.job_id}): IPOPT iteration" in (
            panel.status.content
        )
        assert panel.progress.visible and not panel.cancel.disabled
        assert panel.solve.disabled and panel.baseline.disabled and panel.all_stages.disabled
        assert studio.gait.solve(baseline=True) is None  # a click from another tab
        assert studio.gait.solves.running is running
        assert running.job_id in studio.notifier.last_error
        assert done.wait(GUARD_S), "the solve did not end"
    finally:
        disconnect()
    assert [solve.job_id for solve in ended] == [running.job_id]
    assert ended[0].result is not None and ended[0].result.converged
    assert not panel.solve.disabled and not panel.progress.visible and panel.cancel.disabled


def _eom_residual(robot, planar, result, k: int) -> float:
    """Largest |Gᵀ (RNEA(q, v, a) − Σ Jᵀ f) − B u| at node k, by pinocchio on the full robot
    with frames at the sole edges' mid-points built here (not the planner's own functions)."""
    import pinocchio as pin

    model, data, frame_ids = model_with_sole_edge_frames(robot)
    q, v = planar.to_full_q(result.q[k]), planar.to_full_v(result.q[k], result.v[k])
    a = planar.to_full_a(result.q[k], result.v[k], result.a[k])
    tau = pin.rnea(model, data, q, v, a).copy()
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    forces = result.contact_forces_N[k]
    for i, fid in enumerate(frame_ids):
        J = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)[:3]
        tau -= J.T @ np.array([forces[i, 0], 0.0, forces[i, 1]])
    residual = planar.velocity_map(result.q[k]).T @ tau
    residual[3:] -= result.u[k]
    return float(np.abs(residual).max())


def test_a_fine_mesh_solves_by_refinement_and_says_its_stage(studio):
    """Knots set to 120 through the slider (above the coarse default): the worker solves 38
    knots, then 120 from them; the status names each stage while it runs, and the gait has
    120 knots whose equations of motion hold (pinocchio, at every node)."""
    panel = studio.gait.panel
    knots = 120
    panel.sliders["knots"].value = knots
    statuses: list[str] = []
    disconnect = studio.gait.progressed.connect(lambda _i: statuses.append(panel.status.content))
    try:
        ended = solve_gait(studio)
    finally:
        disconnect()
    result = ended.result
    assert result is not None and result.converged, ended.error or result.status
    assert result.settings.knots == knots and len(result.t) == knots + 2
    assert any("stage 1 of 2: the coarse 38-knot solve" in s for s in statuses)
    assert any(f"stage 2 of 2: {knots} knots from the coarse solve" in s for s in statuses)
    robot, planar = studio.state.robot, studio.gait.planar
    worst = max(_eom_residual(robot, planar, result, k) for k in range(len(result.t)))
    assert worst < 1e-4  # N / N·m: the collocation holds to IPOPT's tolerance at the knots


def test_k0_2_after_a_solve_re_solves_in_the_panel(studio):
    """Issue 23 defect 2 as a user meets it: Solve, move K0 from 6.5 to 2, Solve again. It
    converges (warm, from the first gait) and the panel says it solved."""
    panel = studio.gait.panel
    first = solve_gait(studio)
    assert first.result is not None and first.result.converged
    panel.sliders["K0"].value = 2.0
    ended = solve_gait(studio)
    assert ended.warm and ended.result is not None
    assert ended.result.converged, panel.status.content
    assert panel.status.content.startswith("Solved in"), panel.status.content
    assert studio.gait.results.symmetric is ended.result


def test_a_cold_restart_shows_while_the_solve_runs(studio):
    """The panel says so live once a warm solve runs past the warm start's budget (the solve
    restarts cold then): fed the worker's progress events for such a solve."""
    import dataclasses

    from app.core.collocation.gait_problem import WARM_ITERATIONS_BEFORE_FALLBACK
    from app.studio.gait_text import Solve

    session = studio.gait
    settings = session.panel.settings(False)
    session.solves.running = Solve("gait-test", settings, studio.state.robot, warm=True)
    session.solves.history = ([], [], [])
    session._on_progress("gait-test", 3, 1.0, 1e-3)
    assert "restarted cold" not in session.panel.status.content
    session.solves.history = ([], [], [])
    session._on_progress("gait-test", WARM_ITERATIONS_BEFORE_FALLBACK + 1, 1.0, 1e-3)
    assert "restarted cold" in session.panel.status.content
    session.solves.running = dataclasses.replace(session.solves.running, warm=False)
    session.solves.history = ([], [], [])
    session._on_progress("gait-test", WARM_ITERATIONS_BEFORE_FALLBACK + 1, 1.0, 1e-3)
    assert "restarted cold" not in session.panel.status.content
    session.solves.running = None
