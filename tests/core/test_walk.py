"""Planning and walking servo_biped with its default settings, checked independently.

The gait (one periodic cycle, 38 knots) and a 4-step walk built from it are solved once per
module. Checks use pinocchio on the full robot, not the planner's own readouts:
- bounds between the knots: the gait exported at 1 ms (10+ samples per collocation interval):
  swing soles above the floor, joint speeds and ranges, pelvis height, knee flexion;
- touch-down speed from pinocchio's frame velocities at the pre-impact knots;
- the impact loss equals the drop of pinocchio's kinetic energy ½ vᵀ M v across the impact;
- the walk read back from its CSV: feet in contact neither slide nor sink (pinocchio forward
  kinematics of the sole corners), it starts and ends at rest, the feet take turns;
- the whole-body QP follows at least 95 % of the walk's samples.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pinocchio as pin
import pytest

from app.core.collocation.defaults import PAPER_LEG_M, default_settings, robot_gait_defaults
from app.core.collocation.dircon import GaitProblem, GaitSettings, to_trajectory
from app.core.collocation.job_key import GaitProblemKey
from app.core.dynamics.wbc import torque_feedforward
from app.core.motions.csv_files import read_trajectory_csv, write_trajectory_csv
from app.core.robot.loading import load_robot
from app.core.walking.walk import WalkError, build_walk
from app.gait_jobs import build_gait_problem

CONTACT_DRIFT_M = 1e-4
"""Largest sole-corner motion of a foot in contact (the planner's stance points drift by
micrometres between knots; 1e-4 m is the existing planner tests' bound)."""
FOLLOW_RATE = 0.95


@pytest.fixture(scope="module")
def robot():
    return load_robot("servo_biped")


@pytest.fixture(scope="module")
def planned(robot):
    settings = dataclasses.replace(default_settings(robot), knee_flexion_min_rad=0.3)
    problem = GaitProblem(robot)
    result = problem.solve(settings)
    assert result.converged, result.status
    return problem, result


@pytest.fixture(scope="module")
def walk(planned, tmp_path_factory, robot):
    problem, result = planned
    walk = build_walk(problem.model, result, steps=4, step_width_m=0.12)
    path = tmp_path_factory.mktemp("walk") / "walk.csv"
    write_trajectory_csv(walk.trajectory, path, robot)
    return walk, read_trajectory_csv(path, robot)


def sole_corners(robot, data, q):
    """World sole corners (2, 4, 3) of (left, right) at q."""
    pin.framesForwardKinematics(robot.model, data, q)
    return np.array(
        [
            [data.oMf[robot.link_frame_ids[f.link]].act(c) for c in f.sole_corners_m]
            for f in robot.feet
        ]
    )


def standing_height(robot):
    """Base height above the lowest sole corner with every joint at zero [m]."""
    data = robot.model.createData()
    return -sole_corners(robot, data, pin.neutral(robot.model))[..., 2].min()


def test_defaults_scale_the_papers_case_and_take_the_urdfs_limits(robot):
    defaults = robot_gait_defaults(robot)
    ratio = standing_height(robot) / PAPER_LEG_M
    paper = GaitSettings()
    assert defaults.length_ratio == pytest.approx(ratio)
    assert defaults.settings.swing_height_m == pytest.approx(paper.swing_height_m * ratio, abs=1e-4)
    # Steps of 0.26 leg (the step length test is tests/core/test_gait_defaults_walk.py).
    assert defaults.settings.step_length_m == pytest.approx(0.52 * defaults.leg_m, abs=1e-4)
    assert defaults.settings.tau_max_Nm == min(j.effort for j in robot.joints)  # 6 N·m
    assert defaults.settings.qd_max == min(j.velocity for j in robot.joints)
    assert defaults.notes == ()
    assert default_settings(load_robot("dircon_biped")) == paper


def test_a_urdf_without_limits_gets_stated_defaults(write_urdf):
    text = load_robot("servo_biped").source.read_text()
    text = text.replace('effort="6', 'effort="0').replace('velocity="6', 'velocity="0')
    defaults = robot_gait_defaults(load_robot(write_urdf(text)))
    assert any("no effort limit" in note for note in defaults.notes)
    assert any("no velocity limit" in note for note in defaults.notes)
    assert defaults.settings.qd_max == GaitSettings().qd_max


def test_bounds_hold_between_the_knots(robot, planned):
    problem, result = planned
    s = result.settings
    trajectory = to_trajectory(robot, result, dt=0.001)
    data = robot.model.createData()
    planar = problem.model
    knees = [
        planar.joint_idx_q[j - 3]
        for j in (planar.leg_joints[side][1] for side in ("left", "right"))
    ]
    for k in range(trajectory.n_samples):
        q = trajectory.q[k]
        corners = sole_corners(robot, data, q)
        for side, touching in enumerate(trajectory.contacts[k]):
            if not touching:
                assert corners[side, :, 2].min() >= -1e-6  # swing sole above the floor
                assert corners[side, :, 2].max() <= s.swing_height_m + 1e-6
        joints = trajectory.v[k, planar.joint_idx_v]
        assert np.abs(joints).max() <= s.qd_max * (1 + 1e-3)
        assert np.all(
            q[planar.joint_idx_q] >= robot.model.lowerPositionLimit[planar.joint_idx_q] - 1e-6
        )
        assert np.all(
            q[planar.joint_idx_q] <= robot.model.upperPositionLimit[planar.joint_idx_q] + 1e-6
        )
        assert q[2] <= s.pelvis_height_ratio * standing_height(robot) + 1e-6
        assert q[knees].min() >= s.knee_flexion_min_rad - 1e-3  # servo_biped flexes at +q
    assert result.bound_check is not None and result.bound_check.holds


def test_touch_down_speed_and_impact_loss_from_pinocchio(robot, planned):
    problem, result = planned
    planar, model = problem.model, robot.model
    data = model.createData()
    first = [i for i in range(1, len(result.t)) if result.virtual[i]]
    loss = 0.0
    for post, landing in zip(first, robot.feet[::-1], strict=True):  # right lands, then left
        pre = post - 1
        q = planar.to_full_q(result.q[pre])
        v_pre = planar.to_full_v(result.q[pre], result.v[pre])
        v_post = planar.to_full_v(result.q[post], result.v[post])
        pin.forwardKinematics(model, data, q, v_pre)
        pin.updateFramePlacements(model, data)
        fid = robot.link_frame_ids[landing.link]
        for corner in landing.sole_corners_m:
            placement = data.oMf[fid]
            frame_v = pin.getFrameVelocity(model, data, fid, pin.ReferenceFrame.LOCAL)
            v_point = placement.rotation @ (frame_v.linear + np.cross(frame_v.angular, corner))
            assert np.abs(v_point[[0, 2]]).max() <= result.settings.touchdown_speed_max_mps + 1e-6
        M = pin.crba(model, data, q)
        M = np.triu(M) + np.triu(M, 1).T
        loss += 0.5 * v_pre @ M @ v_pre - 0.5 * v_post @ M @ v_post
    assert loss > 0.0
    assert result.impact_loss_J == pytest.approx(loss, rel=1e-6)
    assert result.work_incl_impacts_J == pytest.approx(result.energy_J + loss, rel=1e-6)


def test_walk_feet_neither_slide_nor_sink(robot, walk):
    _, trajectory = walk
    data = robot.model.createData()
    held: dict[int, np.ndarray] = {}
    for k in range(trajectory.n_samples):
        corners = sole_corners(robot, data, trajectory.q[k])
        for side in (0, 1):
            if not trajectory.contacts[k, side]:
                held.pop(side, None)
                assert corners[side, :, 2].min() >= -1e-6  # a swinging foot stays above the floor
                continue
            assert np.abs(corners[side, :, 2]).max() <= CONTACT_DRIFT_M  # flat on the floor
            anchor = held.setdefault(side, corners[side])
            assert np.abs(corners[side] - anchor).max() <= CONTACT_DRIFT_M  # no sliding


def test_walk_starts_and_ends_at_rest_and_takes_four_steps(robot, walk):
    planned_walk, trajectory = walk
    # At rest to the accuracy of the 1 ms one-sided differences the walk takes its v from.
    np.testing.assert_allclose(trajectory.v[0], 0.0, atol=1e-4)
    np.testing.assert_allclose(trajectory.v[-1], 0.0, atol=1e-4)
    assert trajectory.contacts[0].all() and trajectory.contacts[-1].all()
    lifts = sum(
        1
        for k in range(1, trajectory.n_samples)
        for side in (0, 1)
        if trajectory.contacts[k - 1, side] and not trajectory.contacts[k, side]
    )
    assert lifts == 4
    assert len(planned_walk.footprints) == 2 + 4
    data = robot.model.createData()
    widths = sole_corners(robot, data, trajectory.q[0])[:, :, 1].mean(axis=1)
    assert widths[0] - widths[1] == pytest.approx(0.12, abs=1e-6)


def test_walk_sways_over_the_stance_foot(robot, walk):
    """At the middle of each single support the CoM is on the stance foot's side (the lateral
    pendulum crosses the middle at the touch-downs)."""
    _, trajectory = walk
    data = robot.model.createData()
    single = trajectory.contacts.sum(axis=1) == 1
    k = 0
    middles = []
    while k < trajectory.n_samples:
        if single[k]:
            end = k
            while (
                end + 1 < trajectory.n_samples
                and (trajectory.contacts[end + 1] == trajectory.contacts[k]).all()
            ):
                end += 1
            middles.append((k + end) // 2)
            k = end + 1
        else:
            k += 1
    assert len(middles) == 4
    for k in middles:
        com_y = pin.centerOfMass(robot.model, data, trajectory.q[k])[1]
        side = 1.0 if trajectory.contacts[k, 0] else -1.0
        # Leaning at least 3 mm towards the stance foot (4.5 mm at the default 0.2 s single
        # supports: the shorter the support, the smaller the pendulum's sway).
        assert side * com_y > 0.003


def test_the_whole_body_qp_follows_the_walk(robot, walk):
    _, trajectory = walk
    ff = torque_feedforward(robot, trajectory)
    followed = 1.0 - len(ff.infeasible_samples) / trajectory.n_samples
    assert followed >= FOLLOW_RATE, ff.status[ff.infeasible_samples[0]]


def test_walk_refuses_bad_requests(planned):
    problem, result = planned
    with pytest.raises(WalkError, match="steps"):
        build_walk(problem.model, result, steps=0)
    with pytest.raises(WalkError, match="width"):
        build_walk(problem.model, result, steps=2, step_width_m=-0.1)


def test_worker_key_rebuilds_the_problem_for_the_robot():
    import pickle

    key = GaitProblemKey.for_robot("servo_biped", GaitSettings(knots=8))
    assert pickle.loads(pickle.dumps(key)) == key and hash(key) == hash(
        pickle.loads(pickle.dumps(key))
    )
    problem = build_gait_problem(key)
    assert problem.model.robot.name == "servo_biped" and problem.structure == (8, False)


def test_roban_s14_plans_and_walks_balanced():
    """Roban S14 (hip pitch through a 45°-tilted joint, roll and yaw): its default plan
    converges and the whole-body QP follows ≥ 95 % of a 4-step walk on the true 3-D model."""
    from tests.conftest import ROBAN_URDF

    robot = load_robot(ROBAN_URDF)
    problem = GaitProblem(robot)
    result = problem.solve(default_settings(robot))
    assert result.converged, result.status
    walk = build_walk(problem.model, result, steps=4)
    ff = torque_feedforward(robot, walk.trajectory)
    assert 1.0 - len(ff.infeasible_samples) / walk.trajectory.n_samples >= FOLLOW_RATE
