"""Motions without jumps: no joint steps further than its speed limit allows in one sample,
clipped samples are flagged, and torque peaks leave flagged samples out."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from app.core.dynamics.peaks import over_speed_samples, torque_peaks
from app.core.dynamics.wbc import torque_feedforward
from app.core.motions.continuity import DEFAULT_SPEED_LIMIT, limit_joint_steps, speed_limits
from app.core.motions.library import run_motion
from app.core.motions.trajectory import from_configurations
from app.core.robot.loading import load_robot
from tests.conftest import ROBAN_URDF


@pytest.fixture(scope="module")
def servo():
    return load_robot("servo_biped")


def test_a_fast_step_is_scaled_to_the_slowest_limit(servo) -> None:
    """Closed form: joint a moved by 1 rad and joint b by −0.05 rad in dt = 0.01 s, base x by
    0.3 m; a's limit v_a·dt sets α = v_a·dt / 1 rad, and every component is scaled by α."""
    dt = 0.01
    q0 = servo.q_neutral.copy()
    q1 = q0.copy()
    a, b = servo.joints[3], servo.joints[5]
    q1[a.idx_q] += 1.0
    q1[b.idx_q] -= 0.05
    q1[0] += 0.3  # base x
    v_a = a.velocity or DEFAULT_SPEED_LIMIT
    alpha = v_a * dt / 1.0
    q, message = limit_joint_steps(servo, q0, q1, dt)
    assert q[a.idx_q] == pytest.approx(q0[a.idx_q] + v_a * dt, abs=1e-12)
    assert q[b.idx_q] == pytest.approx(q0[b.idx_q] - 0.05 * alpha, abs=1e-12)
    assert q[0] == pytest.approx(q0[0] + 0.3 * alpha, abs=1e-12)
    assert message is not None and a.name in message and "57.3°" in message
    unchanged, none = limit_joint_steps(servo, q0, q0, dt)
    assert none is None and np.array_equal(unchanged, q0)


def test_roban_squats_never_move_a_joint_faster_than_its_limit() -> None:
    """Issue 15: the IK swung Roban's arms 40–68° in one 10 ms sample; now every step is
    within v_max·dt, and the samples where the IK wanted more are flagged (since issue 26 the
    built-in motions hold the arms, and the IK may want no such jump at all)."""
    robot = load_robot(ROBAN_URDF)
    dt = 0.01
    result = run_motion(robot, "one_leg_squats", dt=dt)
    q = result.trajectory.q
    steps = np.array([pin.difference(robot.model, q[k], q[k + 1]) for k in range(len(q) - 1)])
    idx_v = [j.idx_v for j in robot.joints]
    assert np.all(np.abs(steps[:, idx_v]) <= speed_limits(robot) * dt * (1 + 1e-9) + 1e-12)
    flagged = {w.index for w in result.warnings if w.message.startswith("jump:")}
    assert set(result.jump_samples) == flagged
    assert over_speed_samples(robot, result.trajectory) == ()


def test_peaks_leave_flagged_samples_out(servo) -> None:
    """A CoM shift whose knee steps by 1.5 rad between two samples (30 rad/s at dt 0.05 s):
    the jump's samples are flagged as over speed, the peaks are those of the others."""
    base = run_motion(servo, "com_shift", dt=0.05).trajectory
    q = base.q.copy()
    jump = len(q) // 2
    knee = next(j for j in servo.joints if "knee" in j.name)
    q[jump:, knee.idx_q] += 1.5
    traj = from_configurations(servo.model, "jump", servo.joint_names, base.dt, q, base.contacts)
    ff = torque_feedforward(servo, traj)
    peaks = torque_peaks(servo, traj, ff)
    assert jump in peaks.over_speed_samples
    assert set(peaks.flagged_samples) >= set(peaks.infeasible_samples)
    keep = np.ones(len(q), dtype=bool)
    keep[list(peaks.flagged_samples)] = False
    np.testing.assert_array_equal(peaks.max_abs_tau_Nm, np.abs(ff.tau_Nm[keep]).max(axis=0))
    np.testing.assert_array_equal(peaks.max_abs_tau_all_samples_Nm, np.abs(ff.tau_Nm).max(axis=0))
    j = servo.joint_names.index(knee.name)
    assert peaks.max_abs_tau_all_samples_Nm[j] > peaks.max_abs_tau_Nm[j]


def _loop_gaps_m(robot, q: np.ndarray) -> np.ndarray:
    """Per sample, the largest distance [m] between the two frames each declared loop joins,
    from pinocchio's frame placements (not app.core.robot.loops)."""
    model, data = robot.model, robot.model.createData()
    pairs = [(model.getFrameId(lp.link_a), model.getFrameId(lp.link_b)) for lp in robot.tree.loops]
    gaps = np.empty(len(q))
    for k, q_k in enumerate(q):
        pin.framesForwardKinematics(model, data, q_k)
        gaps[k] = max(
            float(np.linalg.norm(data.oMf[a].translation - data.oMf[b].translation))
            for a, b in pairs
        )
    return gaps


@pytest.fixture(scope="module")
def hybrid():
    return load_robot("hybrid_leg_biped")


def test_a_scaled_step_keeps_the_hybrid_legs_loops_closed(hybrid) -> None:
    """Scaling a step uniformly opens a four-bar at second order in α·δ; the scaled pose's
    passive joints are solved again, its actuated joints stay exactly where α put them."""
    from app.core.robot.loops import close_loops

    data = hybrid.model.createData()
    q0 = close_loops(hybrid, hybrid.q_neutral, data).q
    bent = q0.copy()
    knee = next(j for j in hybrid.joints if j.name == "left_knee")
    ankle = next(j for j in hybrid.joints if j.name == "left_ankle")
    bent[knee.idx_q] -= 0.6
    bent[ankle.idx_q] += 0.3
    q1 = close_loops(hybrid, bent, data).q
    assert _loop_gaps_m(hybrid, [q0, q1]).max() < 1e-9
    q, message = limit_joint_steps(hybrid, q0, q1, 0.01)
    assert message is not None
    alpha = (knee.velocity or DEFAULT_SPEED_LIMIT) * 0.01 / 0.6
    assert q[knee.idx_q] == pytest.approx(q0[knee.idx_q] - 0.6 * alpha, abs=1e-12)
    assert q[ankle.idx_q] == pytest.approx(q0[ankle.idx_q] + 0.3 * alpha, abs=1e-12)
    naive = pin.integrate(hybrid.model, q0, alpha * pin.difference(hybrid.model, q0, q1))
    assert _loop_gaps_m(hybrid, [naive])[0] > 1e-7  # the case is one that opens the loop
    assert _loop_gaps_m(hybrid, [q])[0] < 1e-9


def test_hybrid_leg_step_in_place_keeps_every_loop_closed(hybrid) -> None:
    """The hybrid-leg paper's stepping motion: on every sample each four-bar's two sides meet
    to ≤ 1e-9 m (it was 2.1e-5 m on the speed-scaled samples of the third step)."""
    result = run_motion(hybrid, "step_in_place")
    assert any(w.message.startswith("jump:") for w in result.warnings)  # scaled samples exist
    gaps = _loop_gaps_m(hybrid, result.trajectory.q)
    assert gaps.max() <= 1e-9, f"loop open by {gaps.max():.2e} m at sample {gaps.argmax()}"
