"""Torque feed-forward (app.core.dynamics.wbc), checked against independent computations: scipy's
Riccati solver for the CoM LQR, pinocchio's RNEA with the solved contact forces as external
forces, the mass matrix and corner Jacobians from a model with frames added at the sole
corners, static equilibrium (forces sum to m·g, centre of pressure under the CoM), and the
friction pyramids of eq. 11."""

from __future__ import annotations

import dataclasses

import numpy as np
import pinocchio as pin
import pytest
import scipy.linalg

import app.core.dynamics.wbc_qp as wbc_qp
import app.core.dynamics.wbc_reduced as wbc_reduced
from app.core.dynamics.lqr import A_COM, B_COM, lqr_com
from app.core.dynamics.wbc import FeedForward, WbcError, WbcParams, torque_feedforward
from app.core.errors import StudioError
from app.core.motions.library import run_motion
from app.core.motions.trajectory import Trajectory
from tests.conftest import load_robots

RESIDUAL_NM = 1e-6


@pytest.fixture(scope="module")
def robots():
    return load_robots("servo_biped", "roban", "dircon_biped", "hybrid_leg_biped")


def static(robot, q, contacts, n=3) -> Trajectory:
    """The pose q held still for n samples (v = a = 0)."""
    nv = robot.model.nv
    return Trajectory(
        name="static",
        joint_names=robot.joint_names,
        t=np.arange(n) * 0.01,
        q=np.tile(q, (n, 1)),
        v=np.zeros((n, nv)),
        a=np.zeros((n, nv)),
        contacts=np.tile(np.asarray(contacts, dtype=bool), (n, 1)),
    )


def corner_points(robot, q):
    """World positions of the sole corners, shape (2, 4, 3)."""
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, q)
    return np.array(
        [
            [data.oMf[robot.link_frame_ids[foot.link]].act(c) for c in foot.sole_corners_m]
            for foot in robot.feet
        ]
    )


def external_forces(robot, q, ff: FeedForward, k: int) -> list:
    """pinocchio fext (per joint, joint frame) of the corner and loop forces of sample k."""
    model, data = robot.model, robot.model.createData()
    pin.framesForwardKinematics(model, data, q)
    fext = [pin.Force.Zero() for _ in range(model.njoints)]

    def push(frame_id, point, force):
        joint = model.frames[frame_id].parentJoint
        fext[joint] += data.oMi[joint].actInv(pin.Force(force, np.cross(point, force)))

    points = corner_points(robot, q)
    for side, foot in enumerate(robot.feet):
        for c in range(4):
            push(robot.link_frame_ids[foot.link], points[side, c], ff.contact_forces_N[k, side, c])
    for i, loop in enumerate(robot.tree.loops):
        for link, sign in ((loop.link_a, 1.0), (loop.link_b, -1.0)):
            fid = robot.link_frame_ids[link]
            push(fid, data.oMf[fid].translation, sign * ff.loop_forces_N[k, i])
    return fext


def generalised_torque(robot, ff: FeedForward, k: int) -> np.ndarray:
    """Sᵀτ: the actuated torques in their velocity slots, zero elsewhere."""
    out = np.zeros(robot.model.nv)
    out[[joint.idx_v for joint in robot.joints]] = ff.tau_Nm[k]
    return out


def rnea_residual(robot, traj, ff, k) -> float:
    """|RNEA(q, v, q̈, fext) − Sᵀτ|: τ is eq. 10's, base and passive joints are unforced."""
    q, v = traj.q[k], traj.v[k]
    fext = external_forces(robot, q, ff, k)
    tau = pin.rnea(robot.model, robot.model.createData(), q, v, ff.qdd[k], fext)
    return float(np.abs(tau - generalised_torque(robot, ff, k)).max())


def lagrangian_residual(robot, traj, ff, k) -> float:
    """|M q̈ + h − Sᵀτ − Σ J_cᵀ f_c| with corner Jacobians of frames added at the corners."""
    model = pin.Model(robot.model)
    corner_frames = []
    for foot in robot.feet:
        parent = model.getFrameId(foot.link)
        joint = model.frames[parent].parentJoint
        placement = model.frames[parent].placement
        for c, corner in enumerate(foot.sole_corners_m):
            frame = pin.Frame(
                f"{foot.link}_corner{c}",
                joint,
                parent,
                placement * pin.SE3(np.eye(3), corner),
                pin.FrameType.OP_FRAME,
            )
            corner_frames.append(model.addFrame(frame))
    data = model.createData()
    q, v = traj.q[k], traj.v[k]
    M = pin.crba(model, data, q)
    h = pin.nonLinearEffects(model, data, q, v)
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    contact = np.zeros(model.nv)
    for fid, force in zip(corner_frames, ff.contact_forces_N[k].reshape(-1, 3), strict=True):
        J = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)[:3]
        contact += J.T @ force
    assert not robot.tree.loops
    residual = M @ ff.qdd[k] + h - generalised_torque(robot, ff, k) - contact
    return float(np.abs(residual).max())


def check_pyramids(ff: FeedForward, mu: float) -> None:
    f = ff.contact_forces_N
    assert np.all(f[..., 2] >= -1e-9)
    # eq. 11 with edges ±x, ±y: the inscribed pyramid |fx| + |fy| ≤ μ fz, inside the cone.
    assert np.all(np.abs(f[..., 0]) + np.abs(f[..., 1]) <= mu * f[..., 2] + 1e-9)
    assert np.all(np.hypot(f[..., 0], f[..., 1]) <= mu * f[..., 2] + 1e-9)


# --- the CoM LQR (eqs. 1–3) -------------------------------------------------------------------


@pytest.mark.parametrize("q_weight, r_weight", [(10.0, 0.1), (1.0, 1.0), (3.5, 0.02)])
def test_lqr_matches_scipys_riccati_solver(q_weight, r_weight):
    K, S = lqr_com(q_weight, r_weight)
    Q, R = q_weight * np.eye(6), r_weight * np.eye(3)
    S_scipy = scipy.linalg.solve_continuous_are(A_COM, B_COM, Q, R)
    np.testing.assert_allclose(S, S_scipy, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(K, np.linalg.solve(R, B_COM.T @ S_scipy), rtol=1e-10)
    assert np.all(np.linalg.eigvals(A_COM - B_COM @ K).real < 0.0)


def test_lqr_of_the_paper():
    K, _ = lqr_com()  # Q = 10·I6, R = 0.1·I3
    np.testing.assert_allclose(K[0, [0, 3]], [10.0, np.sqrt(120.0)], rtol=1e-12)


def test_lqr_rejects_non_positive_weights():
    with pytest.raises(StudioError, match="positive"):
        lqr_com(0.0, 0.1)


def test_value_function_gives_the_lqr_law(robots):
    """With a = 0 and vanishing w and ε, the QP's CoM acceleration is V's minimiser −K x̄."""
    robot = robots["servo_biped"]
    params = WbcParams(a=0.0, w_qdd=1e-10, epsilon=1e-9)
    ready = run_motion(robot, "com_shift", dt=0.1).trajectory.q[0]  # knees bent
    traj = static(robot, ready, (True, True), n=2)
    x_bar = np.tile([0.002, -0.001, 0.001, 0.0, 0.001, 0.0], (2, 1))
    ff = torque_feedforward(robot, traj, params, com_state_error=x_bar)
    K, _ = lqr_com()
    com_acc = ff.contact_forces_N[0].sum(axis=(0, 1)) / robot.mass_kg + robot.model.gravity.linear
    np.testing.assert_allclose(com_acc, -K @ x_bar[0], atol=1e-5)
    assert rnea_residual(robot, traj, ff, 0) < RESIDUAL_NM


# --- static poses ------------------------------------------------------------------------------


ONE_LEG_SHIFT_M = {"biped_s13": 0.0925}
"""A CoM shift that puts the CoM over the stance sole (Roban S14's hips are 23.5 cm apart:
the paper's 5 cm leaves its CoM off the sole)."""


def one_leg_pose(robot):
    shift = {"shift_m": ONE_LEG_SHIFT_M[robot.name]} if robot.name in ONE_LEG_SHIFT_M else {}
    traj = run_motion(robot, "one_leg_stand", dt=0.05, **shift).trajectory
    assert tuple(traj.contacts[-1]) == (True, False)
    return traj.q[-1]


@pytest.mark.parametrize(
    "name, support",
    [
        ("servo_biped", "double"),
        ("servo_biped", "single"),
        ("roban", "double"),
        ("roban", "single"),
        ("dircon_biped", "double"),  # no ankle roll: it cannot stand on one flat foot (below)
    ],
)
def test_static_pose_is_held_by_forces_inside_the_pyramids(robots, name, support):
    robot = robots[name]
    if support == "double":
        q, contacts = robot.q_neutral, (True, True)
    else:
        q, contacts = one_leg_pose(robot), (True, False)
    params = WbcParams()
    traj = static(robot, q, contacts)
    ff = torque_feedforward(robot, traj, params)
    assert ff.status == ("solved",) * traj.n_samples and len(ff.infeasible_samples) == 0
    check_pyramids(ff, params.mu)
    model, data = robot.model, robot.model.createData()
    weight = robot.mass_kg * -model.gravity.linear[2]
    com = pin.centerOfMass(model, data, q)
    for k in range(traj.n_samples):
        assert rnea_residual(robot, traj, ff, k) < RESIDUAL_NM
        assert lagrangian_residual(robot, traj, ff, k) < RESIDUAL_NM
        assert np.abs(ff.qdd[k]).max() < 1e-3  # static: the plan's q̈ = 0 is followed
        # τ = RNEA(q, 0, 0) − Jᵀλ: gravity held by the contact forces alone.
        tau_static = pin.rnea(
            model, data, q, np.zeros(model.nv), np.zeros(model.nv), external_forces(robot, q, ff, k)
        )
        np.testing.assert_allclose(tau_static, generalised_torque(robot, ff, k), atol=1e-2)
        total = ff.contact_forces_N[k].sum(axis=(0, 1))
        np.testing.assert_allclose(total, [0.0, 0.0, weight], atol=1e-3 * weight)
        # exactly Newton's law with the solved accelerations
        pin.centerOfMass(model, data, q, np.zeros(model.nv), ff.qdd[k])
        np.testing.assert_allclose(
            total, robot.mass_kg * (data.acom[0] - model.gravity.linear), atol=1e-8 * weight
        )
        # centre of pressure under the CoM (flat ground, no horizontal force)
        fz = ff.contact_forces_N[k, ..., 2]
        points = corner_points(robot, q)
        cop = (points[..., :2] * fz[..., None]).sum(axis=(0, 1)) / fz.sum()
        np.testing.assert_allclose(cop, com[:2], atol=1e-3)
        if support == "single":
            assert np.all(ff.contact_forces_N[k, 1] == 0.0)


def test_roban_without_effort_limits_is_noted(robots):
    robot = robots["roban"]
    ff = torque_feedforward(robot, static(robot, robot.q_neutral, (True, True), n=2))
    assert any("no torque limit" in note and robot.joint_names[0] in note for note in ff.notes)


# --- moving trajectories ----------------------------------------------------------------------


def test_com_shift_dynamics_hold_at_every_sample(robots):
    robot = robots["servo_biped"]
    traj = run_motion(robot, "com_shift", dt=0.02).trajectory
    fractions = []
    ff = torque_feedforward(robot, traj, progress=fractions.append)
    assert ff.tau_Nm.shape == (traj.n_samples, robot.n_actuated)
    assert ff.contact_forces_N.shape == (traj.n_samples, 2, 4, 3)
    assert ff.qdd.shape == (traj.n_samples, robot.model.nv) and ff.qp_time_s.shape == traj.t.shape
    assert len(ff.infeasible_samples) == 0
    assert fractions[0] == 0.0 and fractions[-1] == 1.0 and fractions == sorted(fractions)
    check_pyramids(ff, WbcParams().mu)
    for k in range(traj.n_samples):
        assert rnea_residual(robot, traj, ff, k) < RESIDUAL_NM
        assert lagrangian_residual(robot, traj, ff, k) < RESIDUAL_NM
    np.testing.assert_allclose(ff.qdd, traj.a, atol=WbcParams().max_qdd_error)
    # the centre of pressure follows the CoM towards the left foot (slow motion: CoP ≈ ZMP of
    # the point-mass model, c_xy − c_z·c̈_xy / (c̈_z + g))
    model, data = robot.model, robot.model.createData()
    for k in range(0, traj.n_samples, 10):
        pin.centerOfMass(model, data, traj.q[k], traj.v[k], traj.a[k])
        com, acc = data.com[0], data.acom[0]
        zmp = com[:2] - com[2] * acc[:2] / (acc[2] - model.gravity.linear[2])
        fz = ff.contact_forces_N[k, ..., 2]
        cop = (corner_points(robot, traj.q[k])[..., :2] * fz[..., None]).sum(axis=(0, 1)) / fz.sum()
        np.testing.assert_allclose(cop, zmp, atol=2e-3)
    assert ff.contact_forces_N[-1, 0, :, 2].sum() > ff.contact_forces_N[-1, 1, :, 2].sum()


def test_closed_loops_are_supported(robots):
    """hybrid_leg_biped: four-bar loops closed by internal forces, passive joints unforced."""
    robot = robots["hybrid_leg_biped"]
    traj = run_motion(robot, "com_shift", dt=0.05).trajectory
    ff = torque_feedforward(robot, traj)
    assert len(ff.infeasible_samples) == 0
    assert ff.loop_forces_N.shape == (traj.n_samples, len(robot.tree.loops), 3)
    assert np.abs(ff.loop_forces_N).max() > 1.0  # the loops carry load
    for k in range(traj.n_samples):
        assert rnea_residual(robot, traj, ff, k) < RESIDUAL_NM


# --- what cannot be done is reported per sample ---------------------------------------------


def test_com_far_outside_the_stance_foot_is_reported_per_sample(robots):
    robot = robots["servo_biped"]
    over_right = run_motion(robot, "com_shift", side="right", dt=0.05).trajectory.q[-1]
    traj = static(robot, over_right, (True, False), n=4)  # but standing on the left foot
    ff = torque_feedforward(robot, traj)
    assert list(ff.infeasible_samples) == [0, 1, 2, 3]
    assert all(s.startswith("cannot follow the plan") for s in ff.status)
    assert np.all(np.isfinite(ff.tau_Nm))
    for k in range(traj.n_samples):  # still a physically consistent (falling) motion
        assert rnea_residual(robot, traj, ff, k) < RESIDUAL_NM
    check_pyramids(ff, WbcParams().mu)


def test_one_leg_stand_without_ankle_roll_is_reported(robots):
    """dircon_biped's IK cannot bring the CoM over one flat foot (no ankle roll)."""
    robot = robots["dircon_biped"]
    q = one_leg_pose(robot)
    com = pin.centerOfMass(robot.model, robot.model.createData(), q)
    sole = corner_points(robot, q)[0]
    assert not sole[:, 1].min() <= com[1] <= sole[:, 1].max()  # independent: CoM off the sole
    ff = torque_feedforward(robot, static(robot, q, (True, False)))
    assert list(ff.infeasible_samples) == [0, 1, 2]
    assert all("CoM leaves the support" in s or "torque limit" in s for s in ff.status)


def test_absurdly_low_torque_limits_are_reported_per_sample(robots):
    robot = robots["servo_biped"]
    squat = run_motion(robot, "one_leg_squats", dt=0.05).trajectory
    k = int(np.argmin(squat.q[:, 2]))  # deepest squat, on one leg
    traj = static(robot, squat.q[k], squat.contacts[k])
    ff = torque_feedforward(robot, traj, WbcParams(torque_limits_Nm=(1e-3,) * robot.n_actuated))
    assert list(ff.infeasible_samples) == [0, 1, 2]
    assert all(not s.startswith("solved") for s in ff.status)


@pytest.mark.parametrize("solver", ["reduced", "proxqp"])
def test_samples_without_a_solution_hold_the_nearest_solved_values(robots, monkeypatch, solver):
    robot = robots["servo_biped"]
    traj = run_motion(robot, "com_shift", dt=0.1).trajectory
    original = wbc_qp.WholeBodyQp.solve
    calls = []

    def solve(self, sample, **options):
        calls.append(None)
        if len(calls) in (1, 4):  # samples 0 and 3 fail
            return wbc_qp.SampleSolution(False, "made to fail", *(np.zeros(0),) * 3)
        return original(self, sample, **options)

    monkeypatch.setattr(wbc_qp.WholeBodyQp, "solve", solve)
    if solver == "reduced":  # no closed form anywhere: every sample goes through `solve`
        closed_form = wbc_reduced.ReducedQp.unconstrained_batch

        def no_closed_form(self, *args):
            qdd, beta, ok = closed_form(self, *args)
            return qdd, beta, np.zeros_like(ok)

        monkeypatch.setattr(wbc_reduced.ReducedQp, "unconstrained_batch", no_closed_form)
    ff = torque_feedforward(robot, traj, solver=solver)
    assert list(ff.infeasible_samples) == [0, 3]
    assert ff.status[0] == "no solution: made to fail; values held from sample 1 (t = 0.100 s)"
    assert ff.status[3].endswith("held from sample 2 (t = 0.200 s)")
    np.testing.assert_array_equal(ff.tau_Nm[0], ff.tau_Nm[1])
    np.testing.assert_array_equal(ff.contact_forces_N[3], ff.contact_forces_N[2])


# --- bad input --------------------------------------------------------------------------------


def test_a_trajectory_of_another_robot_is_refused(robots):
    traj = run_motion(robots["servo_biped"], "com_shift", dt=0.1).trajectory
    with pytest.raises(WbcError, match="does not fit robot 'dircon_biped'"):
        torque_feedforward(robots["dircon_biped"], traj)
    renamed = dataclasses.replace(traj, joint_names=tuple(reversed(traj.joint_names)))
    with pytest.raises(WbcError, match="different order"):
        torque_feedforward(robots["servo_biped"], renamed)


@pytest.mark.parametrize(
    "field, index, value, message",
    [
        ("v", (1, 7), np.nan, "NaN"),
        ("a", (0, 8), 1e7, "check the units"),
        ("q", (0, 6), 2.0, "quaternions are not unit"),
    ],
)
def test_corrupt_values_are_refused(robots, field, index, value, message):
    robot = robots["servo_biped"]
    traj = static(robot, robot.q_neutral, (True, True))
    getattr(traj, field)[index] = value  # corrupted after construction
    with pytest.raises(WbcError, match=message):
        torque_feedforward(robot, traj)


def test_bad_parameters_are_refused(robots):
    with pytest.raises(WbcError, match="mu must be a positive number"):
        WbcParams(mu=-0.5)
    with pytest.raises(WbcError, match="torque limits"):
        WbcParams(torque_limits_Nm=(float("nan"),))
    robot = robots["servo_biped"]
    with pytest.raises(WbcError, match="12 actuated joints"):
        torque_feedforward(
            robot,
            static(robot, robot.q_neutral, (True, True)),
            WbcParams(torque_limits_Nm=(1.0, 2.0)),
        )
