"""The planar (x, z, pitch) model of dircon_biped against pinocchio on the full 3-D model.

The planar coordinates map to the full ones by q_full = to_full_q(q) (y, roll and yaw zero) and
v_full = G(q) v. G is checked against pinocchio's own configuration difference; then the planar
dynamics must be the projection of the full dynamics on the planar motions:
M_planar = Gᵀ M_full G (CRBA) and τ_planar(q, v, a) = Gᵀ RNEA_full(q, G v, G a + Ġ v), with Ġ v
taken by finite differences. Contact points are compared with frames added to the pinocchio
model at the sole edges' mid-points, and their Jacobians and J̇v with pinocchio's frame
Jacobians and accelerations and with finite differences.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from app.core.collocation.planar_model import CONTACT_NAMES, evaluate
from tests.sole_frames import planar_contact_jacobian

PAPER_TOTAL_MASS_KG = 18.532  # Table 2
FOOT_LENGTH_M = 0.190  # Figure 2


def random_states(planar, n=6, seed=7):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        q = np.concatenate(
            [rng.uniform(-0.3, 0.3, 1), rng.uniform(0.8, 1.1, 1), rng.uniform(-0.5, 0.5, 1)]
            + [rng.uniform(lo, hi, 1) for lo, hi in zip(planar.lower, planar.upper, strict=True)]
        )
        yield q, rng.normal(size=planar.nv), rng.normal(size=planar.nv)


def test_reduction_keeps_the_papers_masses(planar):
    assert planar.mass_kg == pytest.approx(PAPER_TOTAL_MASS_KG)
    assert planar.joint_names == (
        "left_hip_pitch", "left_knee", "left_ankle_pitch",
        "right_hip_pitch", "right_knee", "right_ankle_pitch",
    )  # fmt: skip
    # Base + both hip roll and hip yaw links + both hip pitch links (Table 2).
    assert planar.bodies[0].mass_kg == pytest.approx(7.624 + 2 * (0.922 + 0.776 + 0.743))


def test_configuration_round_trip(planar, full):
    model = full[0]
    for q, _, _ in random_states(planar):
        q_full = planar.to_full_q(q)
        assert np.linalg.norm(q_full[3:7]) == pytest.approx(1.0)
        assert q_full[1] == 0.0
        np.testing.assert_allclose(planar.from_full_q(q_full), q, atol=1e-12)
        for name in ("left_hip_roll", "left_hip_yaw", "right_hip_roll", "right_hip_yaw"):
            assert q_full[model.joints[model.getJointId(name)].idx_q] == 0.0


def test_velocity_map_matches_pinocchio_difference(planar, full):
    model = full[0]
    eps = 1e-6
    for q, v, _ in random_states(planar):
        step = pin.difference(
            model, planar.to_full_q(q - 0.5 * eps * v), planar.to_full_q(q + 0.5 * eps * v)
        )
        np.testing.assert_allclose(step / eps, planar.velocity_map(q) @ v, atol=1e-7)


def test_mass_matrix_is_the_projection_of_crba(planar, full):
    model, data, _ = full
    for q, _, _ in random_states(planar):
        M_full = pin.crba(model, data, planar.to_full_q(q))
        M_full = np.triu(M_full) + np.triu(M_full, 1).T
        G = planar.velocity_map(q)
        np.testing.assert_allclose(evaluate(planar.mass_matrix, q), G.T @ M_full @ G, atol=1e-10)


def _gdot_v(planar, q, v, eps=1e-6):
    """Ġ v by central differences of G along the motion."""
    return (planar.velocity_map(q + eps * v) - planar.velocity_map(q - eps * v)) @ v / (2 * eps)


def test_dynamics_are_the_projection_of_rnea(planar, full):
    model, data, _ = full
    for q, v, a in random_states(planar):
        G = planar.velocity_map(q)
        q_full = planar.to_full_q(q)
        a_full = G @ a + _gdot_v(planar, q, v)
        np.testing.assert_allclose(planar.to_full_a(q, v, a), a_full, atol=1e-7)
        tau_full = pin.rnea(model, data, q_full, G @ v, a_full)
        np.testing.assert_allclose(evaluate(planar.rnea, q, v, a), G.T @ tau_full, atol=1e-6)
        h_full = pin.rnea(model, data, q_full, G @ v, _gdot_v(planar, q, v))
        np.testing.assert_allclose(evaluate(planar.bias, q, v), G.T @ h_full, atol=1e-6)
        gravity = pin.computeGeneralizedGravity(model, data, q_full)
        np.testing.assert_allclose(
            evaluate(planar.bias, q, np.zeros(planar.nv)), G.T @ gravity, atol=1e-10
        )


def test_contact_points_are_the_sole_edge_midpoints(planar, full):
    model, data, frame_ids = full
    for q, _, _ in random_states(planar):
        pin.framesForwardKinematics(model, data, planar.to_full_q(q))
        points = evaluate(planar.contact_positions, q).reshape(4, 2)
        for i, fid in enumerate(frame_ids):
            np.testing.assert_allclose(points[i], data.oMf[fid].translation[[0, 2]], atol=1e-12)
        for side in (0, 2):  # heel to toe is the foot's length
            assert np.linalg.norm(points[side + 1] - points[side]) == pytest.approx(FOOT_LENGTH_M)
    assert CONTACT_NAMES == ("left_heel", "left_toe", "right_heel", "right_toe")


def test_standing_soles_touch_the_ground(robot, planar):
    q = planar.from_full_q(robot.q_neutral)
    np.testing.assert_allclose(evaluate(planar.contact_positions, q)[1::2], 0.0, atol=1e-9)


def test_contact_jacobians(planar, full):
    eps = 1e-6
    for q, _, _ in random_states(planar):
        J = evaluate(planar.contact_jacobian, q)
        # Finite differences of the positions.
        for i in range(planar.nq):
            dq = np.zeros(planar.nq)
            dq[i] = eps
            column = (
                evaluate(planar.contact_positions, q + dq)
                - evaluate(planar.contact_positions, q - dq)
            ) / (2 * eps)
            np.testing.assert_allclose(J[:, i], column, atol=1e-7)
        # Pinocchio's frame Jacobians (world-aligned linear rows x and z) through G.
        np.testing.assert_allclose(J, planar_contact_jacobian(planar, full, q), atol=1e-10)


def test_contact_jdot_v(planar, full):
    model, data, frame_ids = full
    eps = 1e-6
    for q, v, _ in random_states(planar):
        jdot_v = evaluate(planar.contact_jdot_v, q, v)
        J_plus = evaluate(planar.contact_jacobian, q + eps * v)
        J_minus = evaluate(planar.contact_jacobian, q - eps * v)
        np.testing.assert_allclose(jdot_v, (J_plus - J_minus) @ v / (2 * eps), atol=1e-6)
        # Pinocchio: the points' classical acceleration when the planar acceleration is zero.
        q_full = planar.to_full_q(q)
        pin.forwardKinematics(
            model, data, q_full, planar.to_full_v(q, v), planar.to_full_a(q, v, 0 * v)
        )
        for i, fid in enumerate(frame_ids):
            acc = pin.getFrameClassicalAcceleration(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
            np.testing.assert_allclose(jdot_v[2 * i : 2 * i + 2], acc.linear[[0, 2]], atol=1e-9)
