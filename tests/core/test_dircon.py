"""The symmetric gait planner, checked on its output at the 100 Hz samples it hands on.

Independent checks use pinocchio on the full 3-D dircon_biped: the equations of motion through
RNEA with the planned torques and contact forces (projected on the planar motions: the lateral
force and roll/yaw moments a planar gait needs are the job of the paper's coronal limiter), the
stance points' positions and velocities through frames added at the sole edges' mid-points.

Tolerances. At the knots the collocation constraints hold to IPOPT's tolerance (1e-6), so the
equations of motion there are checked to 1e-4 N / N·m. Between knots q(t), v(t) are Hermite
cubics and the forces piecewise linear, exact at knots and collocation points only: the
measured residual on the paper's case is about 0.25 N·m (0.14 % of the robot's weight), so the
100 Hz check is 1.0 N / N·m. Likewise stance points drift by micrometres between knots, and the
Hermite v(t) may overshoot a speed bound by a little between knots.

The paper's case (38 knots) is solved once per module, symmetric and baseline; properties that
do not need it use a 12-knot problem.
"""

from __future__ import annotations

import dataclasses
import pickle

import numpy as np
import pinocchio as pin
import pytest

from app.core.collocation.dircon import (
    GaitProblem,
    GaitResult,
    GaitSettings,
    GaitSettingsError,
    sample_gait,
    to_trajectory,
)

EOM_TOL_KNOTS = 1e-4
EOM_TOL_SAMPLES = 1.0
STANCE_DRIFT_M = 1e-4
STANCE_SPEED_M_S = 5e-3
SPEED_OVERSHOOT = 0.02
"""Relative overshoot of |q̇| ≤ qd_max allowed between knots (Hermite v(t))."""


@pytest.fixture(scope="module")
def paper(planar):
    problem = GaitProblem(planar, knots=38)
    return problem, problem.solve(GaitSettings())


@pytest.fixture(scope="module")
def baseline(planar):
    problem = GaitProblem(planar, knots=38, baseline=True)
    return problem.solve(GaitSettings(baseline=True))


def planar_residual(full, planar, q_full, v_full, a_full, u, forces):
    """Gᵀ (RNEA(q, v, a) − Σ Jᵀ f) − B u: what the planar equations of motion miss."""
    model, data, frame_ids = full
    tau = pin.rnea(model, data, q_full, v_full, a_full).copy()
    pin.computeJointJacobians(model, data, q_full)
    pin.updateFramePlacements(model, data)
    for i, fid in enumerate(frame_ids):
        J = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)[:3]
        tau -= J.T @ np.array([forces[i, 0], 0.0, forces[i, 1]])
    residual = planar.velocity_map(planar.from_full_q(q_full)).T @ tau
    residual[3:] -= u
    return residual


def test_paper_case_converges(paper):
    _, result = paper
    assert result.converged and result.status == "solved", result.status
    assert result.constraint_violation < 1e-6
    assert 0 < result.iterations < 300
    assert len(result.t) == 38 + 2 and result.virtual.sum() == 2
    np.testing.assert_allclose(result.durations_s, [0.18, 0.36, 0.18])  # LSP = RSP = H/2


def test_equations_of_motion_at_knots(paper, planar, full):
    _, r = paper
    worst = 0.0
    for k in range(len(r.t)):
        residual = planar_residual(
            full, planar, planar.to_full_q(r.q[k]), planar.to_full_v(r.q[k], r.v[k]),
            planar.to_full_a(r.q[k], r.v[k], r.a[k]), r.u[k], r.contact_forces_N[k],
        )  # fmt: skip
        worst = max(worst, np.abs(residual).max())
    assert worst < EOM_TOL_KNOTS


def test_equations_of_motion_at_100_hz(paper, robot, planar, full):
    _, r = paper
    traj = to_trajectory(robot, r)
    samples = sample_gait(r, traj.t)
    assert traj.dt == pytest.approx(0.01) and traj.t[-1] == pytest.approx(0.72)
    residuals = [
        planar_residual(
            full, planar, traj.q[k], traj.v[k], traj.a[k], samples.u[k], samples.contact_forces_N[k]
        )
        for k in range(traj.n_samples)
    ]
    worst = np.abs(residuals).max()
    assert worst < EOM_TOL_SAMPLES


def test_trajectory_is_the_full_robot_walking_in_the_plane(paper, robot):
    _, r = paper
    traj = to_trajectory(robot, r)
    assert traj.joint_names == robot.joint_names
    model = robot.model
    for name in ("left_hip_roll", "left_hip_yaw", "right_hip_roll", "right_hip_yaw"):
        joint = model.joints[model.getJointId(name)]
        assert np.all(traj.q[:, joint.idx_q] == 0.0) and np.all(traj.v[:, joint.idx_v] == 0.0)
    assert np.all(traj.q[:, 1] == 0.0)
    # v is the derivative of q: compare with pinocchio's finite differences.
    for k in range(1, traj.n_samples - 1):
        if traj.contacts[k - 1].tolist() != traj.contacts[k + 1].tolist():
            continue  # a touch-down in between: the velocity jumps
        fd = pin.difference(model, traj.q[k - 1], traj.q[k + 1]) / (2 * traj.dt)
        np.testing.assert_allclose(fd, traj.v[k], atol=0.05)
    # Contact schedule: left, then right from the first touch-down, then left again.
    expected_left = (traj.t < 0.18 - 1e-9) | (traj.t >= 0.54 - 1e-9)
    np.testing.assert_array_equal(traj.contacts[:, 0], expected_left)
    np.testing.assert_array_equal(traj.contacts[:, 1], ~expected_left)


def test_stance_points_stay_put_and_forces_stay_in_the_cones(paper, robot, full):
    _, r = paper
    model, data, frame_ids = full
    traj = to_trajectory(robot, r)
    samples = sample_gait(r, traj.t)
    mu = r.settings.mu
    footholds = {0: r.footholds_m[0], 1: r.footholds_m[1], 2: r.footholds_m[2]}
    for k in range(traj.n_samples):
        pin.forwardKinematics(model, data, traj.q[k], traj.v[k])
        pin.updateFramePlacements(model, data)
        stance = 0 if traj.contacts[k, 0] else 1
        points = frame_ids[2 * stance : 2 * stance + 2]
        xs = [data.oMf[fid].translation[0] for fid in points]
        assert np.mean(xs) == pytest.approx(footholds[int(samples.mode[k])], abs=STANCE_DRIFT_M)
        for fid in points:
            assert abs(data.oMf[fid].translation[2]) < STANCE_DRIFT_M
            speed = pin.getFrameVelocity(model, data, fid, pin.LOCAL_WORLD_ALIGNED).linear
            assert np.linalg.norm(speed[[0, 2]]) < STANCE_SPEED_M_S
        forces = samples.contact_forces_N[k]
        for i in (2 * stance, 2 * stance + 1):
            assert forces[i, 1] >= -1e-6
            assert abs(forces[i, 0]) <= mu * forces[i, 1] + 1e-6
        swing = 1 - stance
        assert np.all(forces[2 * swing : 2 * swing + 2] == 0.0)


def test_bounds_hold_at_100_hz(paper, robot, planar, full):
    _, r = paper
    model, data, frame_ids = full
    traj = to_trajectory(robot, r)
    samples = sample_gait(r, traj.t)
    s = r.settings
    assert np.abs(samples.u).max() <= s.tau_max_Nm + 1e-6
    assert np.abs(r.u).max() <= 13.0 + 1e-6
    assert np.abs(samples.v[:, 3:]).max() <= s.qd_max * (1 + SPEED_OVERSHOOT)
    assert np.abs(r.v[:, 3:]).max() <= 6.28 + 1e-6
    joints = samples.q[:, 3:]
    # Table 1: hip pitch ±47°, knee ±63°, ankle ±85° (as in the URDF).
    table1 = np.radians([47, 63, 85, 47, 63, 85])
    assert np.all(np.abs(joints) <= table1 + 1e-3)
    np.testing.assert_allclose(planar.upper, table1, atol=1e-5)
    heights = []
    for k in range(traj.n_samples):
        pin.framesForwardKinematics(model, data, traj.q[k])
        heights.append([data.oMf[fid].translation[2] for fid in frame_ids])
    heights = np.array(heights)
    assert heights.max() <= s.swing_height_m + 1e-3
    assert heights.min() >= -1e-3


def test_step_lengths_within_the_slack_bounds(paper, robot, full):
    _, r = paper
    s = r.settings
    model, data, frame_ids = full
    traj = to_trajectory(robot, r)
    # Footholds measured on the robot: the stance sole centre in the middle of each mode.
    measured = []
    for time_s in (0.09, 0.36, 0.63):
        k = traj.index_at(time_s)
        pin.framesForwardKinematics(model, data, traj.q[k])
        stance = 0 if traj.contacts[k, 0] else 1
        measured.append(
            np.mean(
                [data.oMf[fid].translation[0] for fid in frame_ids[2 * stance : 2 * stance + 2]]
            )
        )
    lsp, rsp = np.diff(measured)
    np.testing.assert_allclose([lsp, rsp], r.step_lengths_m, atol=1e-6)
    assert lsp + rsp == pytest.approx(s.step_length_m, abs=1e-6)
    bound = 2 * max(abs(s.slack_a), abs(s.slack_b)) * s.step_length_m
    assert abs(lsp - rsp) <= bound + 1e-6
    assert s.slack_a - 1e-8 <= r.slack0 <= s.slack_b + 1e-8


def test_exchange_forces_equal_steps_whatever_the_slack_bounds(small):
    """With the joint states exchanged exactly and both soles flat at the touch-downs, the two
    steps are mirror images: slack0 = 0 however wide [a, b] is, and bounds excluding 0 are
    refused with the reason (IPOPT would only run into its iteration limit)."""
    problem, _ = small
    wide = problem.solve(GaitSettings(knots=12, slack_a=-0.3, slack_b=0.3))
    assert wide.converged, wide.status
    assert abs(wide.slack0) < 1e-6
    assert wide.step_lengths_m[0] == pytest.approx(wide.step_lengths_m[1], abs=1e-6)
    refused = problem.solve(GaitSettings(knots=12, slack_a=0.03, slack_b=0.05))
    assert not refused.converged and "exclude 0" in refused.status


def test_joint_states_are_exchanged_and_the_gait_is_periodic(paper, robot):
    _, r = paper
    assert r.exchange_residual < 1e-6
    assert r.periodicity_residual < 1e-6
    end0 = np.where(r.mode == 0)[0][-1]
    end1 = np.where(r.mode == 1)[0][-1]
    left, right = slice(3, 6), slice(6, 9)
    for x in (r.q, r.v):
        np.testing.assert_allclose(x[end0, left], x[end1, right], atol=1e-6)
        np.testing.assert_allclose(x[end0, right], x[end1, left], atol=1e-6)
    traj = to_trajectory(robot, r)
    shifted = traj.q[0].copy()
    shifted[0] += r.settings.step_length_m
    np.testing.assert_allclose(traj.q[-1], shifted, atol=1e-6)
    np.testing.assert_allclose(traj.v[-1], traj.v[0], atol=1e-6)


def test_symmetric_gait_is_not_worse_than_the_baseline(paper, baseline):
    """Table 4 / section 5.4: max joint input 9.8 vs 11.5 N·m, SR 0.772 vs 1.299."""
    _, symmetric = paper
    assert baseline.converged, baseline.status
    assert symmetric.max_abs_tau_Nm <= baseline.max_abs_tau_Nm
    assert symmetric.sr <= baseline.sr
    assert baseline.exchange_residual > 100 * symmetric.exchange_residual


def test_specific_resistance_from_its_definition(paper, planar):
    _, r = paper
    t = np.linspace(0.0, r.duration_s, 20001)
    modes = np.searchsorted(np.cumsum(r.durations_s)[:2], t, side="right")
    samples = sample_gait(r, t, modes)
    power = np.maximum(samples.u * samples.v[:, 3:], 0.0).sum(axis=1)
    energy = float(np.sum(0.5 * (power[1:] + power[:-1]) * np.diff(t)))
    assert r.energy_J == pytest.approx(energy, rel=1e-3)
    assert r.sr == pytest.approx(energy / (18.532 * 9.81 * 0.2), rel=1e-3)


def test_warm_restart_after_a_slider_change(small):
    problem, first = small
    changed = dataclasses.replace(first.settings, K0=5.0)
    warm = problem.solve(changed, warm_start=first)
    cold = problem.solve(changed, cold=True)
    assert warm.converged and cold.converged
    assert warm.iterations < cold.iterations
    assert warm.objective == pytest.approx(cold.objective, rel=1e-3)
    problem.solve(first.settings)  # leave the last good solution as it was


@pytest.mark.parametrize(
    "change, words",
    [
        ({"slack_a": 0.1, "slack_b": -0.1}, "a = 0.1 > b = -0.1"),
        ({"knots": 3}, "at least 5 knots"),
        ({"H_s": float("nan")}, "H_s is nan"),
        # No verdict of infeasibility within max_iter (the warm start then the cold restart
        # stall); the blame measures the torques sitting on their bound.
        ({"tau_max_Nm": 0.1}, "torques at their bound"),
        ({"max_iter": 3}, "iteration limit"),
        ({"knots": 20}, "built for knots = 12"),
    ],
)
def test_bad_settings_give_clear_messages_and_keep_the_last_good_gait(small, change, words):
    problem, _ = small
    good = problem.last_good
    assert good is not None
    result = problem.solve(dataclasses.replace(good.settings, **change))
    assert not result.converged
    assert words in f"{result.status} {result.blame}"
    assert problem.last_good is good


def test_validate_raises_a_studio_error():
    with pytest.raises(GaitSettingsError, match="slack bounds crossed"):
        GaitSettings(slack_a=0.05, slack_b=-0.05).validate()
    with pytest.raises(GaitSettingsError, match="knots"):
        GaitSettings(knots=4).validate()
    with pytest.raises(GaitSettingsError, match="unknown key"):
        GaitSettings.from_mapping({"K3": 1.0})
    with pytest.raises(GaitSettingsError, match="is not a int"):
        GaitSettings.from_mapping({"knots": 12.5})
    assert GaitSettings.from_mapping({"K0": 5}).K0 == 5.0


def test_iteration_callback_reports_and_can_stop(small):
    problem, first = small
    seen = []

    def callback(iteration, objective, violation):
        seen.append((iteration, objective, violation))
        return iteration >= 2

    result = problem.solve(dataclasses.replace(first.settings, K1=2.0), iteration_callback=callback)
    assert [i for i, _, _ in seen] == [0, 1, 2]
    assert all(np.isfinite(f) and v >= 0.0 for _, f, v in seen)
    assert not result.converged and "stopped" in result.status
    assert problem.last_good is not None and problem.last_good.converged


def test_a_raising_callback_stops_the_solve_without_escaping(small):
    problem, first = small

    def broken(iteration, objective, violation):
        raise BrokenPipeError("the studio went away")

    result = problem.solve(dataclasses.replace(first.settings, K1=2.5), iteration_callback=broken)
    assert not result.converged
    assert "BrokenPipeError: the studio went away" in result.status


def test_result_pickles(small):
    """A result crosses the worker's pipe: it pickles and comes back equal."""
    _, result = small
    copy = pickle.loads(pickle.dumps(result))
    assert isinstance(copy, GaitResult)
    np.testing.assert_array_equal(copy.q, result.q)


def test_paper_defaults_walk_on_bent_knees_with_a_torque_like_the_papers(paper, robot):
    """With the pelvis held 1.5 % below its straight-leg height (the default), the knees stay
    bent through the whole gait, as on the paper's robot, and the largest torque comes near
    the paper's 9.8 N·m (Table 4) instead of the 2.5 N·m of a straight-legged gait."""
    from app.core.papers import TABLE4

    _, result = paper
    trajectory = to_trajectory(robot, result, dt=0.001)
    knees = [
        robot.model.joints[robot.model.getJointId(n)].idx_q for n in ("left_knee", "right_knee")
    ]
    flexion = trajectory.q[:, knees]
    assert flexion.min() > 0.15 or (-flexion).min() > 0.15  # one sign of bend all along
    assert 0.75 * TABLE4.max_abs_tau_Nm[0] <= result.max_abs_tau_Nm <= TABLE4.max_abs_tau_Nm[1]


def test_a_walk_of_dircon_biped_says_why_it_has_no_sway(small, planar):
    """dircon_biped has no ankle roll: its walk stays sagittal and says so."""
    from app.core.walking.walk import build_walk

    _, result = small
    walk = build_walk(planar, result, steps=2)
    assert np.abs(walk.com_y_m).max() == 0.0
    assert any("no ankle roll" in note for note in walk.notes)
