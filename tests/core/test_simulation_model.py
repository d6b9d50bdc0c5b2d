"""The MuJoCo model made from a robot has pinocchio's dynamics: mass, CoM, joint-space inertia.

References: pinocchio's own algorithms (pin.crba, pin.centerOfMass) at seeded random
configurations, for the three built-ins, Roban S14 and SigmaBan. MuJoCo's free joint has its
linear velocity in the world and pinocchio's in the base, so the matrices are compared through
the velocity map v_pin = T·v_mj, T = diag(Rᵀ, I, P): M_mj = Tᵀ·M_pin·T.
"""

from __future__ import annotations

import mujoco
import numpy as np
import pinocchio as pin
import pytest

from app.core.robot.loading import load_robot
from app.core.simulation.engine import pin_to_qpos, qpos_to_pin
from app.core.simulation.errors import SimulationInputError
from app.core.simulation.mjcf import SimOptions, build_sim_model
from tests.conftest import ROBAN_URDF, SIGMABAN_URDF, tiny_biped_urdf

ROBOTS = ["servo_biped", "dircon_biped", "hybrid_leg_biped", str(ROBAN_URDF), str(SIGMABAN_URDF)]


def _velocity_map(sim, q: np.ndarray, nv_mj: int) -> np.ndarray:
    T = np.zeros((sim.nv_pin, nv_mj))
    T[:3, :3] = pin.XYZQUATToSE3(q[:7]).rotation.T
    T[3:6, 3:6] = np.eye(3)
    for i_pin, adr in sim.pin_dof:
        T[i_pin, adr] = 1.0
    return T


def _unseen_urdf(write_urdf) -> str:
    """A robot none of the others is like: the tiny biped with a continuous head joint
    (pinocchio stores it as cos, sin) on a prismatic neck, about tilted axes."""
    extra = (
        '<link name="neck"><inertial><mass value="0.3"/><inertia ixx="0.002" iyy="0.002" '
        'izz="0.003" ixy="0.0001" ixz="0" iyz="0"/></inertial></link>'
        '<link name="head"><inertial><origin xyz="0.02 0 0.05"/><mass value="0.4"/>'
        '<inertia ixx="0.002" iyy="0.0015" izz="0.0015" ixy="0" ixz="0.0002" iyz="0"/>'
        "</inertial></link>"
        '<joint name="neck_slide" type="prismatic"><origin xyz="0 0 0.05"/><axis xyz="0 0.6 0.8"/>'
        '<parent link="pelvis"/><child link="neck"/>'
        '<limit lower="-0.05" upper="0.05" effort="50" velocity="1"/></joint>'
        '<joint name="head_spin" type="continuous"><origin xyz="0 0 0.05" rpy="0.3 0 0"/>'
        '<axis xyz="1 0 0"/><parent link="neck"/><child link="head"/>'
        '<limit effort="2" velocity="6"/></joint>'
    )
    return str(write_urdf(tiny_biped_urdf(extra=extra)))


@pytest.mark.parametrize("source", [*ROBOTS, "unseen"])
def test_mass_com_and_joint_space_inertia_match_pinocchio(source, write_urdf):
    robot = load_robot(_unseen_urdf(write_urdf) if source == "unseen" else source)
    if source == "unseen":
        kinds = {joint.kind for joint in robot.joints}
        assert {"continuous", "prismatic", "revolute"} <= kinds
    assert not [note for note in build_sim_model(robot).notes if "inertia" in note]
    armature = 0.02
    sim = build_sim_model(robot, SimOptions(armature_kgm2=armature))
    m = mujoco.MjModel.from_xml_string(sim.xml)
    d = mujoco.MjData(m)
    model, data = robot.model, robot.model.createData()
    assert m.body_subtreemass[0] == pytest.approx(sum(i.mass for i in model.inertias), rel=1e-12)
    np.random.seed(7)  # pin.randomConfiguration draws from numpy's global generator
    lower = np.maximum(model.lowerPositionLimit, -3.0)
    upper = np.minimum(model.upperPositionLimit, 3.0)
    for _ in range(3):
        q = pin.randomConfiguration(model, lower, upper)
        pin_to_qpos(sim, q, d.qpos)
        mujoco.mj_forward(m, d)
        np.testing.assert_allclose(d.subtree_com[0], pin.centerOfMass(model, data, q), atol=1e-12)
        M_mj = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, d, M_mj)
        M_pin = pin.crba(model, data, q)
        M_pin = np.triu(M_pin) + np.triu(M_pin, 1).T
        T = _velocity_map(sim, q, m.nv)
        expected = T.T @ M_pin @ T
        expected[sim.actuated_dof, sim.actuated_dof] += armature
        np.testing.assert_allclose(M_mj, expected, atol=1e-10 * np.abs(expected).max())
        # The configuration maps back unchanged (continuous joints through their angle).
        back = qpos_to_pin(sim, d.qpos)
        assert np.abs(pin.difference(model, q, back)).max() < 1e-12


@pytest.mark.parametrize("source", ROBOTS)
def test_soles_are_where_the_robot_has_them(source):
    """The sole-centre sites sit at the centres of the detected sole rectangles."""
    robot = load_robot(source)
    sim = build_sim_model(robot)
    m = mujoco.MjModel.from_xml_string(sim.xml)
    d = mujoco.MjData(m)
    q = robot.q_neutral
    pin_to_qpos(sim, q, d.qpos)
    mujoco.mj_forward(m, d)
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, q)
    for foot, site in zip(robot.feet, sim.sole_sites, strict=True):
        T = data.oMf[robot.link_frame_ids[foot.link]]
        centre = T.rotation @ foot.sole_corners_m.mean(axis=0) + T.translation
        np.testing.assert_allclose(d.site(site).xpos, centre, atol=1e-12)


def test_loops_become_equality_constraints_that_hold_at_the_closed_pose():
    robot = load_robot("hybrid_leg_biped")
    sim = build_sim_model(robot)
    m = mujoco.MjModel.from_xml_string(sim.xml)
    assert m.neq == len(robot.tree.loops) == 4
    d = mujoco.MjData(m)
    pin_to_qpos(sim, robot.q_neutral, d.qpos)
    mujoco.mj_forward(m, d)
    for i in range(m.neq):
        gap = d.site(f"loop{i}_a").xpos - d.site(f"loop{i}_b").xpos
        assert np.linalg.norm(gap) < 1e-9


def test_an_impossible_inertia_converts_with_a_note(write_urdf):
    """URDFs in the wild break the triangle inequality; MuJoCo refuses them unless balanced."""
    text = tiny_biped_urdf().replace(
        '<link name="left_thigh"><inertial><mass value="0.4"/><inertia ixx="0.001" iyy="0.001" '
        'izz="0.001"',
        '<link name="left_thigh"><inertial><mass value="0.4"/><inertia ixx="0.001" iyy="0.001" '
        'izz="0.005"',
    )
    assert text != tiny_biped_urdf()
    sim = build_sim_model(load_robot(str(write_urdf(text))))
    assert any("impossible inertia" in note and "left_hip_pitch" in note for note in sim.notes)


def test_a_foot_without_sole_geometry_is_refused(write_urdf):
    robot = load_robot(str(write_urdf(tiny_biped_urdf(foot_geometry=""))))
    with pytest.raises(SimulationInputError, match="no sole geometry"):
        build_sim_model(robot)


def test_convex_hulls_are_an_option():
    robot = load_robot("servo_biped")
    soles = build_sim_model(robot, SimOptions(links_collide=False)).xml
    plain = mujoco.MjModel.from_xml_string(soles)
    hulls = mujoco.MjModel.from_xml_string(build_sim_model(robot, SimOptions(hulls=True)).xml)
    assert plain.nmesh == 0 and plain.ngeom == 3  # floor and two soles
    assert hulls.nmesh > 0 and hulls.ngeom > plain.ngeom
