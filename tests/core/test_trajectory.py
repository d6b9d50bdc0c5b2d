"""from_configurations against closed-form motions: joint sines and a yawing, moving base.

Errors are compared with the leading term of the finite-difference error, so a first-order
scheme (or a wrong frame for the base twist) fails where a second-order one passes.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from app.core.motions.trajectory import Trajectory, TrajectoryError, from_configurations
from app.core.robot.loading import load_robot
from app.core.robot.model import RobotModel

A, OMEGA, PHASE = 0.4, 2 * np.pi * 1.5, 0.7
"""Amplitude [rad], angular frequency [rad/s] and phase [rad] of the joint sine."""


@pytest.fixture(scope="module")
def robot() -> RobotModel:
    return load_robot("servo_biped")


def _sine_motion(robot: RobotModel, dt: float, n: int) -> tuple[Trajectory, int]:
    knee = next(j for j in robot.joints if j.name == "left_knee")
    t = np.arange(n) * dt
    q = np.tile(robot.q_neutral, (n, 1))
    q[:, knee.idx_q] = A * np.sin(OMEGA * t + PHASE)
    traj = from_configurations(
        robot.model, "sine", robot.joint_names, dt, q, np.ones((n, 2), dtype=bool)
    )
    return traj, knee.idx_v


def test_joint_velocity_and_acceleration_match_the_derivatives_of_a_sine(robot) -> None:
    dt, n = 0.01, 101
    traj, iv = _sine_motion(robot, dt, n)
    t = traj.t
    inner = slice(1, -1)
    v_err = traj.v[inner, iv] - A * OMEGA * np.cos(OMEGA * t[inner] + PHASE)
    a_err = traj.a[inner, iv] + A * OMEGA**2 * np.sin(OMEGA * t[inner] + PHASE)
    # Leading error terms of the central differences: A ω³ dt² / 6 and A ω⁴ dt² / 12.
    assert np.abs(v_err).max() <= 1.1 * A * OMEGA**3 * dt**2 / 6
    assert np.abs(a_err).max() <= 1.1 * A * OMEGA**4 * dt**2 / 12
    # One-sided velocity at the ends: first order, error ≈ (dt / 2) |q̈| = A ω² dt |sin| / 2.
    end_err = traj.v[0, iv] - A * OMEGA * np.cos(PHASE)
    assert abs(end_err) == pytest.approx(A * OMEGA**2 * dt * np.sin(PHASE) / 2, rel=0.1)
    # Acceleration at the ends repeats its neighbour.
    assert traj.a[0, iv] == traj.a[1, iv] and traj.a[-1, iv] == traj.a[-2, iv]
    # Nothing else moves.
    others = np.delete(traj.v, iv, axis=1)
    assert np.abs(others).max() < 1e-12


def test_halving_the_step_divides_the_error_by_four(robot) -> None:
    errors = []
    for dt, n in ((0.02, 51), (0.01, 101)):
        traj, iv = _sine_motion(robot, dt, n)
        exact = A * OMEGA * np.cos(OMEGA * traj.t + PHASE)
        errors.append(np.abs(traj.v[1:-1, iv] - exact[1:-1]).max())
    assert 3.5 < errors[0] / errors[1] < 4.5


def _yaw_matrix(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def test_constant_yaw_rate_gives_constant_angular_velocity_in_the_base_frame(robot) -> None:
    """Base turning at ω about world z while moving at constant world velocity: the angular
    velocity is (0, 0, ω) in every sample; the linear velocity is the world velocity seen from
    the rotating base, R(ωt)ᵀ v_world, as pinocchio's base twist is in the base frame."""
    dt, n, yaw_rate = 0.01, 80, 1.3
    v_world = np.array([0.3, -0.1, 0.05])
    t = np.arange(n) * dt
    q = np.tile(robot.q_neutral, (n, 1))
    for k, tk in enumerate(t):
        placement = pin.SE3(_yaw_matrix(yaw_rate * tk), robot.q_neutral[:3] + v_world * tk)
        q[k, :7] = pin.SE3ToXYZQUAT(placement)
    traj = from_configurations(
        robot.model, "yaw", robot.joint_names, dt, q, np.ones((n, 2), dtype=bool)
    )
    np.testing.assert_allclose(traj.v[:, 3:6], np.tile([0.0, 0.0, yaw_rate], (n, 1)), atol=1e-9)
    np.testing.assert_allclose(traj.a[:, 3:6], 0.0, atol=1e-6)
    expected = np.array([_yaw_matrix(yaw_rate * tk).T @ v_world for tk in t])
    speed = np.linalg.norm(v_world[:2])
    # Central differences of a vector turning at ω: error ≈ |v| ω² dt² / 6 inside.
    assert np.abs(traj.v[1:-1, :3] - expected[1:-1]).max() <= 1.1 * speed * yaw_rate**2 * dt**2 / 6
    # Its derivative in the base frame: -ω ẑ × (Rᵀ v_world).
    expected_a = np.array([-np.cross([0.0, 0.0, yaw_rate], e) for e in expected])
    assert np.abs(traj.a[1:-1, :3] - expected_a[1:-1]).max() <= speed * yaw_rate**3 * dt**2
    assert np.abs(traj.v[:, 6:]).max() < 1e-12


def test_trajectory_refuses_too_few_samples_and_uneven_times(robot) -> None:
    q = np.tile(robot.q_neutral, (1, 1))
    with pytest.raises(TrajectoryError, match="at least 2"):
        from_configurations(robot.model, "one", robot.joint_names, 0.01, q, np.ones((1, 2)))
    traj, _ = _sine_motion(robot, 0.01, 5)
    with pytest.raises(TrajectoryError, match="fixed step"):
        Trajectory(
            name="uneven",
            joint_names=traj.joint_names,
            t=np.array([0.0, 0.01, 0.02, 0.04, 0.05]),
            q=traj.q,
            v=traj.v,
            a=traj.a,
            contacts=traj.contacts,
        )
