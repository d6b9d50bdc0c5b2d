"""The planar reduction of other bipeds against pinocchio on their full 3-D models.

servo_biped (12 leg joints, hip yaw/roll before the pitch joints) and SigmaBan (every joint
turns about its own z axis; the pitch joints are found from their world axes): the planar
dynamics must be the projection of pinocchio's CRBA and RNEA on the planar motions
(M_planar = Gᵀ M G, τ_planar = Gᵀ RNEA(q, G v, G a + Ġ v)), the contact points the sole edges'
mid-points, as for dircon_biped in test_planar_model.py.

Tolerance. SigmaBan's CAD export leaves its pitch axes ε ≈ 1e-5 rad off the y axis, which the
planar model treats as exactly y: the projection is then exact only to O(ε). ε is measured here
from pinocchio, and values are compared to 1e-9 + 10 ε |value|; servo_biped's axes are exact.

Robots the planner cannot handle are refused with a StudioError that says why.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pinocchio as pin
import pytest

from app.core.collocation.dircon import GaitProblem, PlanarModel, PlanarModelError
from app.core.collocation.planar_model import evaluate
from app.core.errors import StudioError
from app.core.robot.loading import load_robot
from tests.conftest import ROBAN_URDF, SIGMABAN_URDF, tiny_biped_urdf
from tests.core.test_planar_model import random_states
from tests.sole_frames import planar_contact_jacobian


@pytest.fixture(
    scope="module",
    params=["servo_biped", str(SIGMABAN_URDF), "roban-light-hip"],
    ids=["servo", "sigmaban", "roban-light-hip"],
)
def robot(request):
    if request.param == "roban-light-hip":
        return light_hip_links(load_robot(ROBAN_URDF))
    return load_robot(request.param)


def light_hip_links(robot):
    """Roban S14 with the two bodies inside each hip group made massless: the only bodies the
    planar model moves approximately (with the thigh, see hip_group.py). Its planar model
    must then be exact."""
    model = robot.model.copy()
    for side in "lr":
        for link in (1, 2):
            model.inertias[model.getJointId(f"leg_{side}{link}_joint")] = pin.Inertia.Zero()
    return dataclasses.replace(robot, model=model)


@pytest.fixture(scope="module")
def misalignment(robot, planar):
    """ε: the largest angle between a planar joint's world axis and y at the neutral pose."""
    model = robot.model
    data = model.createData()
    pin.computeJointJacobians(model, data, pin.neutral(model))
    worst = 0.0
    virtual = {planar.joint_names[k] for k in planar.hip_groups}
    for name in set(planar.joint_names) - virtual:
        jid = model.getJointId(name)
        J = pin.getJointJacobian(model, data, jid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        worst = max(worst, float(np.arccos(min(1.0, abs(J[4, model.joints[jid].idx_v])))))
    assert worst < 1e-4
    return worst


def close(actual, desired, eps):
    desired = np.asarray(desired)
    np.testing.assert_allclose(actual, desired, atol=1e-9 + 10 * eps * np.abs(desired).max())


def _gdot_v(planar, q, v, h=1e-6):
    return (planar.velocity_map(q + h * v) - planar.velocity_map(q - h * v)) @ v / (2 * h)


def test_mass_matrix_is_the_projection_of_crba(planar, full, misalignment):
    model, data, _ = full
    for q, _, _ in random_states(planar):
        M = pin.crba(model, data, planar.to_full_q(q))
        M = np.triu(M) + np.triu(M, 1).T
        G = planar.velocity_map(q)
        close(evaluate(planar.mass_matrix, q), G.T @ M @ G, misalignment)


def test_dynamics_are_the_projection_of_rnea(planar, full, misalignment):
    model, data, _ = full
    for q, v, a in random_states(planar):
        G = planar.velocity_map(q)
        a_full = G @ a + _gdot_v(planar, q, v)
        tau = pin.rnea(model, data, planar.to_full_q(q), G @ v, a_full)
        np.testing.assert_allclose(planar.to_full_a(q, v, a), a_full, atol=1e-7)
        close(evaluate(planar.rnea, q, v, a), G.T @ tau, max(misalignment, 1e-7))


def test_contact_jacobians(planar, full, misalignment):
    for q, _, _ in random_states(planar):
        J = evaluate(planar.contact_jacobian, q)
        pinocchio_J = planar_contact_jacobian(planar, full, q)
        for rows in range(0, len(J), 2):  # each point's tolerance on its own scale
            close(J[rows : rows + 2], pinocchio_J[rows : rows + 2], misalignment)


def test_planar_joints_are_the_leg_pitch_joints(robot, planar):
    model = robot.model
    data = model.createData()
    pin.computeJointJacobians(model, data, pin.neutral(model))
    virtual = {planar.joint_names[k] for k in planar.hip_groups}
    for name in set(planar.joint_names) - virtual:
        jid = model.getJointId(name)
        J = pin.getJointJacobian(model, data, jid, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        axis = J[3:, model.joints[jid].idx_v]
        assert abs(abs(axis[1]) - 1.0) < 1e-9, name  # turns about world y
        assert abs(axis[0]) < 1e-4 and abs(axis[2]) < 1e-4
    assert len(planar.joint_names) == 6
    left = np.array(planar.joint_names)[planar.leg_joints["left"] - 3]
    assert all(("left" in n or "_l" in n) for n in left)
    # Every body of the robot is somewhere in the planar tree: the masses add up.
    assert planar.mass_kg == pytest.approx(robot.mass_kg, rel=1e-12)


def test_contact_points_are_the_sole_edge_midpoints(robot, planar, full, misalignment):
    model, data, frame_ids = full
    for q, _, _ in random_states(planar):
        pin.framesForwardKinematics(model, data, planar.to_full_q(q))
        points = evaluate(planar.contact_positions, q).reshape(4, 2)
        for i, fid in enumerate(frame_ids):
            close(points[i], data.oMf[fid].translation[[0, 2]], misalignment)


def test_com_is_pinocchios(robot, planar, misalignment):
    model, data = robot.model, robot.model.createData()
    for q, _, _ in random_states(planar):
        com = pin.centerOfMass(model, data, planar.to_full_q(q))
        close(evaluate(planar.com, q), com[[0, 2]], misalignment)


def test_standing_height_from_pinocchio(robot, planar):
    model, data = robot.model, robot.model.createData()
    q = planar.to_full_q(np.zeros(planar.nq))  # base at the origin, every joint at zero
    pin.framesForwardKinematics(model, data, q)
    lowest = min(
        (data.oMf[robot.link_frame_ids[foot.link]].act(c))[2]
        for foot in robot.feet
        for c in foot.sole_corners_m
    )
    assert planar.standing_height_m == pytest.approx(-lowest, abs=1e-12)


def test_roban_hip_groups_move_the_thigh_by_pure_pitch():
    robot = load_robot(ROBAN_URDF)
    planar = PlanarModel(robot)
    assert set(planar.hip_groups) == {0, 3}  # one virtual hip pitch per leg
    model, data = robot.model, robot.model.createData()
    for q, _, _ in random_states(planar):
        pin.forwardKinematics(model, data, planar.to_full_q(q))
        for k, side in ((0, "l"), (3, "r")):
            thigh = data.oMi[model.getJointId(f"leg_{side}3_joint")].rotation
            base = pin.exp3(np.array([0.0, q[2], 0.0]))
            expected = base @ pin.exp3(np.array([0.0, q[3 + k], 0.0]))
            np.testing.assert_allclose(thigh, expected, atol=1e-10)
        np.testing.assert_allclose(planar.from_full_q(planar.to_full_q(q)), q, atol=1e-10)


def test_roban_dynamics_are_close_to_pinocchios_with_its_real_hip_links():
    """With the hip groups' inner bodies (2.9 kg per leg, CoMs within 5 cm of the hip centre)
    moved with the thigh, M and τ stay within 1 % of pinocchio's, the CoM within 2 mm."""
    robot = load_robot(ROBAN_URDF)
    planar = PlanarModel(robot)
    model, data = robot.model, robot.model.createData()
    for q, v, a in random_states(planar):
        G = planar.velocity_map(q)
        M = pin.crba(model, data, planar.to_full_q(q))
        M = G.T @ (np.triu(M) + np.triu(M, 1).T) @ G
        assert np.abs(evaluate(planar.mass_matrix, q) - M).max() <= 0.01 * np.abs(M).max()
        tau = G.T @ pin.rnea(model, data, planar.to_full_q(q), G @ v, planar.to_full_a(q, v, a))
        assert np.abs(evaluate(planar.rnea, q, v, a) - tau).max() <= 0.01 * np.abs(tau).max()
        com = pin.centerOfMass(model, data, planar.to_full_q(q))[[0, 2]]
        assert np.abs(evaluate(planar.com, q) - com).max() <= 2e-3


# -- robots the planner refuses ----------------------------------------------------------------


def test_legs_without_an_ankle_pitch_are_refused(write_urdf):
    robot = load_robot(write_urdf(tiny_biped_urdf()))  # hip pitch and knee only
    with pytest.raises(StudioError, match="2 pitch joint"):
        GaitProblem(robot, knots=8)


def test_legs_without_pitch_joints_are_refused(write_urdf):
    text = tiny_biped_urdf().replace('<axis xyz="0 1 0"/>', '<axis xyz="1 0 0"/>')
    with pytest.raises(PlanarModelError, match=r"0 pitch joint\(s\) \(none\)"):
        PlanarModel(load_robot(write_urdf(text)))


def test_a_fixed_base_robot_is_refused(write_urdf):
    robot = load_robot("servo_biped")
    fixed = type(robot).__new__(type(robot))
    fixed.__dict__.update({**robot.__dict__, "floating_base": False})
    with pytest.raises(PlanarModelError, match="fixed base"):
        PlanarModel(fixed)


def test_closed_loop_legs_are_refused():
    with pytest.raises(PlanarModelError, match="closed kinematic loops"):
        PlanarModel(load_robot("hybrid_leg_biped"))
