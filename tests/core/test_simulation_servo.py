"""The servo law in the step loop, against closed forms and invariants.

- An arm on a compliant servo, horizontal when commanded to 0, holds the gravity torque
  m·g·L·cos θ: it settles where K·dz(0 − q, b/2) = −m·g·L·cos(q + θ_base), i.e.
  q = c·m·g·L·cos(q + θ_base) + b/2 (fixed point, solved here by iteration).
- A free-falling robot moving its joints keeps its centroidal angular momentum, and its linear
  momentum grows by m·g·t (pinocchio's computeCentroidalMomentum on the simulated states).
- A very stiff servo (linear command ramps) follows servo_biped's CoM shift within 0.1°.
- hybrid_leg_biped's four-bars stay closed (pinocchio's loop residual) while it moves.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pinocchio as pin
import pytest

from app.core.motions.library import run_motion
from app.core.motions.trajectory import from_configurations
from app.core.robot.loading import load_robot
from app.core.robot.loops import loop_residual
from app.core.servo.model import ServoModel, base_roll_pitch, joint_angles
from app.core.simulation.engine import FALL_TILT_DEG, POST_FALL_S, run_engine
from app.core.simulation.errors import SimulationDiverged, SimulationInputError
from app.core.simulation.mjcf import SimOptions
from app.core.simulation.run import prepare, simulate

ARM_MASS_KG, ARM_LENGTH_M, G = 0.5, 0.2, 9.81

STOOL_WITH_ARM = f"""<?xml version="1.0"?>
<robot name="stool_arm">
  <link name="pelvis"><inertial><mass value="6"/>
    <inertia ixx="0.05" iyy="0.05" izz="0.05" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><box size="0.2 0.3 0.1"/></geometry></visual></link>
  <link name="left_foot"><inertial><mass value="0.5"/>
    <inertia ixx="0.001" iyy="0.001" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><box size="0.2 0.1 0.02"/></geometry></visual></link>
  <link name="right_foot"><inertial><mass value="0.5"/>
    <inertia ixx="0.001" iyy="0.001" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><box size="0.2 0.1 0.02"/></geometry></visual></link>
  <link name="arm"><inertial><origin xyz="{ARM_LENGTH_M} 0 0"/><mass value="{ARM_MASS_KG}"/>
    <inertia ixx="1e-6" iyy="1e-6" izz="1e-6" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="left_fix" type="fixed"><origin xyz="0 0.1 -0.2"/>
    <parent link="pelvis"/><child link="left_foot"/></joint>
  <joint name="right_fix" type="fixed"><origin xyz="0 -0.1 -0.2"/>
    <parent link="pelvis"/><child link="right_foot"/></joint>
  <joint name="arm_pitch" type="revolute"><origin xyz="0 0 0.1"/><axis xyz="0 1 0"/>
    <parent link="pelvis"/><child link="arm"/>
    <limit lower="-1.5" upper="1.5" effort="20" velocity="6"/></joint>
</robot>
"""


@pytest.fixture(scope="module")
def stool(tmp_path_factory):
    path = tmp_path_factory.mktemp("stool") / "stool.urdf"
    path.write_text(STOOL_WITH_ARM)
    robot = load_robot(str(path))
    traj = from_configurations(
        robot.model,
        "hold",
        robot.joint_names,
        0.01,
        np.tile(robot.q_neutral, (101, 1)),
        np.ones((101, 2), bool),
    )
    return robot, traj


def _closed_form_hang(c_rad_per_Nm: float, half_play_rad: float, base_pitch: float) -> float:
    q = 0.0
    for _ in range(100):
        q = c_rad_per_Nm * ARM_MASS_KG * G * ARM_LENGTH_M * math.cos(q + base_pitch) + half_play_rad
    return q


@pytest.mark.parametrize(
    ("compliance_deg_per_Nm", "backlash_deg"), [(1.4, 0.0), (5.0, 0.0), (0.1, 4.0), (1.4, 1.0)]
)
def test_an_arm_on_a_compliant_servo_hangs_at_the_closed_form_angle(
    stool, compliance_deg_per_Nm, backlash_deg
):
    robot, traj = stool
    servo = ServoModel(robot.joint_names, [compliance_deg_per_Nm], [backlash_deg])
    result = simulate(robot, traj, np.zeros((traj.n_samples, 1)), servo)
    assert not result.fell
    hang = result.q_joints_rad[-1, 0]
    expected = _closed_form_hang(
        math.radians(compliance_deg_per_Nm), math.radians(backlash_deg / 2), result.pitch_rad[-1]
    )
    assert math.degrees(abs(hang - expected)) < 0.005
    assert hang > 0.0  # gravity pulls the arm down: positive about +y
    # The stool stands still: its weight is on its soles.
    total = result.contact_force_N[-1, :, 2].sum()
    assert total == pytest.approx(robot.mass_kg * G, rel=2e-3)


def test_a_very_stiff_servo_tracks_the_com_shift(servo_biped, com_shift):
    q_plan = joint_angles(servo_biped, com_shift.q)
    result = simulate(
        servo_biped,
        com_shift,
        q_plan,
        ServoModel.rigid(servo_biped.joint_names),
        SimOptions(command_hold="linear"),
    )
    assert not result.fell
    assert np.degrees(np.abs(result.q_joints_rad - q_plan)).max() < 0.1
    # Both soles carry the weight throughout: a quasi-static shift.
    assert result.contact_force_N[:, :, 2].sum(axis=1) == pytest.approx(
        servo_biped.mass_kg * G, rel=0.05
    )


def _free_fall_momentum_error(robot, start, timestep_s: float) -> tuple[float, float]:
    """Largest deviation of the centroidal momentum from (m·g·t, 0) while falling and
    swinging the joints ±0.3 rad at 2.5 Hz: (linear [kg·m/s], angular [kg·m²/s])."""
    n = 41
    t = np.arange(n) * 0.01
    q0 = start.copy()
    q0[2] += 3.0
    traj = from_configurations(
        robot.model, "fall", robot.joint_names, 0.01, np.tile(q0, (n, 1)), np.zeros((n, 2), bool)
    )
    q_plan = joint_angles(robot, traj.q)
    signs = np.sign(np.arange(robot.n_actuated) % 3 - 0.5)
    wiggle = q_plan + 0.3 * np.sin(2 * np.pi * 2.5 * t)[:, None] * signs
    servo = ServoModel(robot.joint_names, np.full(12, 1.4), np.full(12, 0.5))
    options = SimOptions(armature_kgm2=0.0, timestep_s=timestep_s)
    inp = prepare(robot, traj, wiggle, servo, options, settle_s=0.0)
    run = run_engine(dataclasses.replace(inp, on_floor=False, detect_falls=False))
    assert np.degrees(np.ptp(run.q_joints_rad, axis=0)).max() > 20.0  # the joints really swing
    model, data = robot.model, robot.model.createData()
    h = np.array(
        [
            pin.computeCentroidalMomentum(model, data, q, v).vector
            for q, v in zip(run.q, run.v, strict=True)
        ]
    )
    expected = np.outer(t, [0.0, 0.0, -G * robot.mass_kg])
    return float(np.abs(h[:, :3] - expected).max()), float(np.abs(h[:, 3:]).max())


def test_with_convex_hulls_the_feet_still_carry_the_robot(servo_biped, com_shift):
    """The feet's own hulls touch the floor with their soles: they count as feet (no false
    fall) and their forces as the feet's (the two still carry the weight)."""
    q_plan = joint_angles(servo_biped, com_shift.q)
    servo = ServoModel.rigid(servo_biped.joint_names)
    options = SimOptions(hulls=True, command_hold="linear")
    result = simulate(servo_biped, com_shift, q_plan, servo, options)
    assert not result.fell
    total = result.contact_force_N[:, :, 2].sum(axis=1)
    assert total == pytest.approx(servo_biped.mass_kg * G, rel=0.05)


def test_free_fall_conserves_momentum(servo_biped, com_shift):
    """The servos' torques are internal: centroidal angular momentum stays 0 and linear
    momentum grows by m·g·t. MuJoCo's integrator is first order: the deviation shrinks
    tenfold with a ten times shorter step, and is small at 0.1 ms."""
    coarse = _free_fall_momentum_error(servo_biped, com_shift.q[0], 1e-3)
    fine = _free_fall_momentum_error(servo_biped, com_shift.q[0], 1e-4)
    scale = G * servo_biped.mass_kg * 0.4  # the momentum gained in 0.4 s
    assert fine[0] < 0.2 * coarse[0] and fine[1] < 0.2 * coarse[1]
    assert fine[0] < 3e-3 * scale and fine[1] < 1e-3


def test_the_hybrid_legs_loops_stay_closed():
    robot = load_robot("hybrid_leg_biped")
    traj = run_motion(robot, "com_shift").trajectory
    result = simulate(robot, traj, joint_angles(robot, traj.q), ServoModel.rigid(robot.joint_names))
    data = robot.model.createData()
    worst = max(np.abs(loop_residual(robot, q, data)).max() for q in result.q)
    assert worst < 1e-3
    assert not result.fell


def test_soft_servos_topple_the_one_leg_stand(servo_biped):
    """3 °/(N·m) servos cannot hold servo_biped on one leg: the verdict's time is the first
    sample at which the torso's roll, computed by pinocchio's convention from the simulated
    configurations, is 30° off the plan's."""
    robot = servo_biped
    traj = run_motion(robot, "one_leg_stand").trajectory
    servo = ServoModel(robot.joint_names, np.full(12, 3.0), np.full(12, 0.5))
    result = simulate(robot, traj, joint_angles(robot, traj.q), servo)
    assert result.fell and "roll" in result.fall_reason
    roll, _ = base_roll_pitch(result.q)
    planned, _ = base_roll_pitch(traj.q)
    off = np.degrees(np.abs(roll - planned))
    k = traj.index_at(result.fall_time_s)
    assert k > 0 and off[k] > FALL_TILT_DEG and np.all(off[:k] <= FALL_TILT_DEG)
    assert result.simulated_until_s == pytest.approx(result.fall_time_s + POST_FALL_S, abs=0.011)


def test_bad_inputs_say_what_is_wrong(servo_biped, com_shift):
    robot, traj = servo_biped, com_shift
    q_plan = joint_angles(robot, traj.q)
    servo = ServoModel.rigid(robot.joint_names)
    other = load_robot("dircon_biped")
    with pytest.raises(SimulationInputError, match="other joints"):
        simulate(other, traj, q_plan[:, :10], ServoModel.rigid(other.joint_names))
    bad = q_plan.copy()
    bad[5, 2] = np.nan
    with pytest.raises(SimulationInputError, match="finite"):
        simulate(robot, traj, bad, servo)
    bad[5, 2] = robot.joints[2].upper + 0.1  # 5.73°
    with pytest.raises(SimulationInputError, match="outside the joint limits") as refused:
        simulate(robot, traj, bad, servo)
    assert f"{robot.joints[2].name} at t = {traj.t[5]:.2f} s" in str(refused.value)
    assert "5.7° beyond its upper limit" in str(refused.value)
    with pytest.raises(SimulationInputError, match="shape"):
        simulate(robot, traj, q_plan[:, :5], servo)
    negative = ServoModel(robot.joint_names, np.full(12, -1.0), np.zeros(12))
    with pytest.raises(SimulationInputError, match="negative"):
        simulate(robot, traj, q_plan, negative)


def test_a_blow_up_is_an_error_not_nan(stool, tmp_path, monkeypatch):
    """A servo far too stiff (and strong) for a 10 ms step diverges: reported, not returned
    as NaN or as MuJoCo's silent reset, and no MUJOCO_LOG.TXT is left in the folder."""
    monkeypatch.chdir(tmp_path)
    path = tmp_path / "strong.urdf"
    path.write_text(STOOL_WITH_ARM.replace('effort="20"', 'effort="1e6"'))
    robot = load_robot(str(path))
    traj = stool[1]
    servo = ServoModel(robot.joint_names, [1e-6], [0.0])
    with pytest.raises(SimulationDiverged, match="blew up"):
        simulate(
            robot,
            traj,
            np.full((traj.n_samples, 1), 0.5),
            servo,
            SimOptions(timestep_s=0.01, armature_kgm2=0.0),
        )
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()


def test_a_blow_up_during_the_motion_is_found_at_its_sample(stool, tmp_path):
    """A servo too stiff for a 10 ms step that holds the arm still, then is commanded a
    1 rad jump at 0.5 s, blows up a few samples after the jump: reported at the same sample
    whether MuJoCo's actuators step the servo a block at a time or the Python law steps it
    tick by tick."""
    path = tmp_path / "strong.urdf"
    path.write_text(STOOL_WITH_ARM.replace('effort="20"', 'effort="1e6"'))
    robot = load_robot(str(path))
    traj = stool[1]
    q_cmd = np.zeros((traj.n_samples, 1))
    q_cmd[50:] = 1.0
    servo = ServoModel(robot.joint_names, [1e-4], [0.0])
    inp = prepare(robot, traj, q_cmd, servo, SimOptions(timestep_s=0.01, armature_kgm2=0.0))
    messages = []
    for in_mujoco in (True, False):
        with pytest.raises(SimulationDiverged, match="blew up") as blown:
            run_engine(dataclasses.replace(inp, servo_in_mujoco=in_mujoco))
        messages.append(str(blown.value))
    assert messages[0] == messages[1]
    t_s = float(messages[0].split("t = ")[1].split(" s")[0])
    assert 0.5 < t_s < 0.6
