"""Keyframe interpolation: the minimum-jerk law checked on the sampled motion through
pinocchio's forward kinematics, planted stance feet, contacts, and clear errors."""

from __future__ import annotations

import dataclasses

import numpy as np
import pinocchio as pin
import pytest

from app.core.errors import StudioError
from app.core.motions.keyframes import Keyframe, KeyframeError, capture_keyframe, interpolate
from app.core.motions.poses import pose_context
from app.core.robot.loading import load_robot

DT = 0.01
LIFT = np.array([0.02, -0.01, 0.03])  # right foot: forwards, outwards, up [m]
YAW = np.deg2rad(20.0)


def s_min_jerk(tau):
    """The minimum-jerk law, written independently of the module under test."""
    tau = np.clip(tau, 0.0, 1.0)
    return 10 * tau**3 - 15 * tau**4 + 6 * tau**5


@pytest.fixture(scope="module")
def servo():
    return load_robot("servo_biped")


@pytest.fixture(scope="module")
def ready(servo):
    return pose_context(servo).q_ready


@pytest.fixture(scope="module")
def lift_motion(servo, ready):
    """Ready -> right foot lifted and turned (1 s) -> back down (0.8 s), standing on the left
    foot; pelvis held, CoM free (the polygon off: the point is the interpolant)."""
    start = capture_keyframe(servo, ready, "both", "start", 0.0)
    start = dataclasses.replace(start, com_xy=None)
    up = start.T_world_right.copy()
    up[:3, 3] += LIFT
    up[:3, :3] = pin.rpy.rpyToMatrix(0.0, 0.0, -YAW) @ up[:3, :3]
    lifted = dataclasses.replace(
        start, name="lifted", duration_s=1.0, T_world_right=up, stance="left"
    )
    down = dataclasses.replace(start, name="down", duration_s=0.8, stance="left")
    keyframes = [start, lifted, down]
    result = interpolate(servo, keyframes, dt=DT, com_in_support=False)
    return keyframes, result


def foot_path(robot, q, side):
    data = robot.model.createData()
    fid = robot.model.getFrameId(robot.foot(side).link)
    out = []
    for q_k in q:
        pin.framesForwardKinematics(robot.model, data, q_k)
        out.append(data.oMf[fid].homogeneous.copy())
    return np.array(out)


def test_samples_and_duration(lift_motion):
    _, result = lift_motion
    traj = result.trajectory
    assert traj.n_samples == 181 and traj.dt == pytest.approx(DT)
    assert traj.duration == pytest.approx(1.8)
    assert result.warnings == ()


def test_moving_foot_follows_the_minimum_jerk_law(servo, lift_motion):
    keyframes, result = lift_motion
    t = result.trajectory.t
    T = foot_path(servo, result.trajectory.q, "right")
    p0, p1 = keyframes[0].T_world_right[:3, 3], keyframes[1].T_world_right[:3, 3]
    first = t <= 1.0 + 1e-9
    expected = p0 + s_min_jerk(t[first] / 1.0)[:, None] * (p1 - p0)
    assert np.abs(T[first, :3, 3] - expected).max() < 1e-3
    second = t >= 1.0 - 1e-9
    expected = p1 + s_min_jerk((t[second] - 1.0) / 0.8)[:, None] * (p0 - p1)
    assert np.abs(T[second, :3, 3] - expected).max() < 1e-3
    # Orientation: slerp with the same law (the yaw angle between the keyframes' feet).
    yaw = np.array(
        [pin.log3(keyframes[0].T_world_right[:3, :3].T @ R)[2] for R in T[first, :3, :3]]
    )
    assert np.abs(yaw - (-YAW) * s_min_jerk(t[first])).max() < np.deg2rad(0.5)


def test_zero_velocity_and_acceleration_at_keyframes(servo, lift_motion):
    _, result = lift_motion
    p = foot_path(servo, result.trajectory.q, "right")[:, :3, 3]
    v = np.gradient(p, DT, axis=0)
    a = np.gradient(v, DT, axis=0)
    distance = np.linalg.norm(LIFT)
    peak_v = 1.875 * distance / 1.0  # max of s'(τ) = 15/8 at τ = 1/2
    peak_a = 5.7735 * distance / 1.0**2  # max of s''(τ) = 10/√3 at τ = 1/2 ∓ √3/6
    assert np.linalg.norm(v[:101], axis=1).max() == pytest.approx(peak_v, rel=0.02)
    assert np.linalg.norm(v[100:], axis=1).max() == pytest.approx(peak_v / 0.8, rel=0.02)
    assert np.linalg.norm(a[5:95], axis=1).max() == pytest.approx(peak_a, rel=0.05)
    assert np.linalg.norm(v[50]) == pytest.approx(peak_v, rel=0.02)
    # At the keyframes v = a = 0; finite differences leave O(dt) of the jerk, 60·d/T³ there
    # (a cubic law would leave a = 6·d/T², about peak_a).
    jerk_dt = 60.0 * distance / 0.8**3 * DT
    for index in (0, 100, 180):
        assert np.linalg.norm(v[index]) < 0.01 * peak_v
    for index in (1, 100, 179):
        second_difference = (p[index + 1] - 2 * p[index] + p[index - 1]) / DT**2
        assert np.linalg.norm(second_difference) < 2 * jerk_dt < 0.5 * peak_a


def test_stance_foot_stays_planted_and_contacts(servo, lift_motion):
    _, result = lift_motion
    traj = result.trajectory
    left = foot_path(servo, traj.q, "left")[:, :3, 3]
    assert np.linalg.norm(left - left[0], axis=1).max() < 1e-4
    right_z = foot_path(servo, traj.q, "right")[:, 2, 3]
    assert traj.contacts[:, 0].all()
    in_air = right_z > 1e-3 + 1e-9
    assert np.array_equal(traj.contacts[:, 1], ~in_air)
    assert traj.contacts[0, 1] and traj.contacts[-1, 1] and not traj.contacts[100, 1]


def test_velocities_are_finite_differences(lift_motion):
    traj = lift_motion[1].trajectory
    model = load_robot("servo_biped").model
    k = 60
    central = pin.difference(model, traj.q[k - 1], traj.q[k + 1]) / (2 * DT)
    assert np.allclose(traj.v[k], central, atol=1e-9)


def test_unreachable_target_is_reported_per_sample(servo, ready, lift_motion):
    keyframes, _ = lift_motion
    far = keyframes[1].T_world_right.copy()
    far[:3, 3] += (0.0, 0.0, 1.0)
    bad = dataclasses.replace(keyframes[1], name="too high", T_world_right=far)
    result = interpolate(servo, [keyframes[0], bad], dt=0.05, com_in_support=False)
    assert result.warnings and {w.keyframe for w in result.warnings} == {"too high"}
    assert any("right target out of reach" in w.message for w in result.warnings)
    assert result.warnings[-1].index == result.trajectory.n_samples - 1
    assert any("'too high'" in line for line in result.summary())


@pytest.mark.parametrize(
    "change, words",
    [
        ({"duration_s": 0.0}, ["keyframe 1", "'lifted'", "duration"]),
        ({"duration_s": -1.0}, ["'lifted'", "positive"]),
        ({"duration_s": float("nan")}, ["'lifted'", "nan"]),
        ({"com_xy": np.array([np.nan, 0.0])}, ["'lifted'", "com_xy", "finite"]),
        ({"T_world_right": np.full((4, 4), np.nan)}, ["'lifted'", "T_world_right"]),
        ({"stance": "both"}, ["'lifted'", "right foot stands", "mm away"]),
        ({"stance": "middle"}, ["'lifted'", "stance"]),
    ],
)
def test_bad_keyframes_raise_clear_errors(servo, lift_motion, change, words):
    keyframes, _ = lift_motion
    bad = dataclasses.replace(keyframes[1], **change)
    with pytest.raises(KeyframeError) as error:
        interpolate(servo, [keyframes[0], bad, keyframes[2]], dt=0.05)
    assert isinstance(error.value, StudioError)
    for word in words:
        assert word in str(error.value)


def test_too_few_keyframes_and_bad_dt(servo, lift_motion):
    keyframes, _ = lift_motion
    with pytest.raises(KeyframeError, match="at least 2 keyframes, got 1"):
        interpolate(servo, keyframes[:1])
    with pytest.raises(KeyframeError, match="time step"):
        interpolate(servo, keyframes, dt=0.0)


def test_keyframe_without_configuration_is_solved_from_standing(servo, lift_motion):
    keyframes, _ = lift_motion
    first = dataclasses.replace(keyframes[0], q=None, T_world_pelvis=None)
    result = interpolate(servo, [first, keyframes[1]], dt=0.05, com_in_support=False)
    T = foot_path(servo, result.trajectory.q[-1:], "right")[0]
    assert np.linalg.norm(T[:3, 3] - keyframes[1].T_world_right[:3, 3]) < 1e-3


def test_keyframe_is_a_frozen_value():
    kf = Keyframe("a", 1.0, np.eye(4), np.eye(4))
    with pytest.raises(dataclasses.FrozenInstanceError):
        kf.name = "b"  # type: ignore[misc]


def test_the_stance_slide_check_in_reused_data_equals_full_forward_kinematics(servo):
    """The per-sample slide check places only the stance feet, in data reused across samples;
    it must measure what full forward kinematics on fresh data measures."""
    from app.core.motions.keyframe_guards import _slide_m

    robot = servo
    rng = np.random.default_rng(4)
    start = {"left": np.eye(4), "right": np.eye(4)}
    start["left"][:3, 3], start["right"][:3, 3] = rng.normal(size=3), rng.normal(size=3)
    scratch = robot.model.createData()
    for _ in range(20):
        q = pin.randomConfiguration(robot.model)
        q[:3] = rng.normal(size=3)
        placements = robot.link_placements(q, robot.model.createData())
        for stance, sides in (
            ("left", ("left",)),
            ("right", ("right",)),
            ("both", ("left", "right")),
        ):
            expected = max(
                np.linalg.norm(placements[robot.foot(s).link][:3, 3] - start[s][:3, 3])
                for s in sides
            )
            assert _slide_m(robot, scratch, start, q, stance) == pytest.approx(expected, abs=1e-12)
