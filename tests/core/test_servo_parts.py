"""Servo parts in the simulation: a servo.toml naming catalogue servos (checked), the part's law
(statics, no-load speed, energy balance to 1 %), and a whole robot standing on real servos."""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np
import pytest
from scipy.optimize import brentq

from app.core.motions.library import run_motion
from app.core.robot.loading import load_robot
from app.core.servo.catalogue import load_catalogue
from app.core.servo.model import joint_angles
from app.core.servo.parts import ServoPartsError, parts_from_mapping, read_parts_toml
from app.core.simulation.part_law import PartLoop, part_servo_law
from app.core.simulation.run import simulate_commands

CATALOGUE = load_catalogue()
# BAM's MX-64 m1 fit and firmware, typed from the shared files (the m1 fit is the one the
# simulation's friction model goes with).
KT, R, ARMATURE = 1.6224667906987444, 3.949433673232461, 0.011951238325312509
BASE, VISCOUS = 0.09038677246291783, 0.011691602145974832
VIN, KP, GAIN, MAX_PWM = 15.0, 32.0, 0.158, 0.9625


def _one_joint(**settings):
    return parts_from_mapping({"servo": "mx64", **settings}, ("hinge",), CATALOGUE, "test")


def test_a_part_per_joint_with_firmware_overrides():
    parts = parts_from_mapping(
        {"servo": "mx106", "kp": 20, "joints": {"b": {"servo": "mx64", "vin_V": 12.0}}},
        ("a", "b"),
        CATALOGUE,
        "servo.toml",
    )
    a, b = parts.parts
    assert (a.servo, a.firmware.kp, a.firmware.vin_V) == ("mx106", 20, 15.0)
    assert (b.servo, b.firmware.kp, b.firmware.vin_V) == ("mx64", 20, 12.0)
    assert b.stiffness_Nm_per_rad == pytest.approx(KT * 12.0 * GAIN * 20 / R)
    assert b.dead_band_deg == 0.33  # the MX-64's published backlash
    model = parts.servo_model()
    assert model.compliance_deg_per_Nm[1] == pytest.approx(math.degrees(R / (KT * 12 * GAIN * 20)))


@pytest.mark.parametrize(
    ("data", "message"),
    [
        ({"joints": {"a": {"servo": "mx64"}}}, "without a servo, first b"),
        ({"servo": "mx999"}, "'mx999' is not in the catalogue"),
        ({"servo": "mx28"}, "no identified motor model"),
        ({"servo": "mx64", "kp": -3}, "kp is -3"),
        ({"servo": "mx64", "kp": 1e6}, "outside the firmware's range"),
        ({"servo": "mx64", "vin_V": float("nan")}, "vin_V"),
        ({"servo": "mx64", "dead_band_deg": 45}, "dead_band_deg"),
        ({"servo": "mx64", "joints": {"c": {"kp": 3}}}, "no joint named 'c'"),
        ({"servo": "mx64", "joints": {"a": {"compliance_deg_per_Nm": 1}}}, "takes servo"),
        ({"servo": "mx64", "stiffness": 3}, "unknown key"),
    ],
)
def test_bad_parts_are_one_line_naming_the_field(data, message):
    with pytest.raises(ServoPartsError) as caught:
        parts_from_mapping(data, ("a", "b"), CATALOGUE, "servo.toml")
    assert message in str(caught.value) and "\n" not in str(caught.value)


def test_a_parts_file_is_read_and_checked(tmp_path):
    path = tmp_path / "servo.toml"
    path.write_text('servo = "mx64"\nkp = 32\n[joints.b]\nservo = "mx106"\n')
    parts = read_parts_toml(path, ("a", "b"), CATALOGUE)
    assert [p.servo for p in parts.parts] == ["mx64", "mx106"]
    path.write_text('servo = "mx64"\nkp = nan\n')
    with pytest.raises(ServoPartsError, match="kp"):
        read_parts_toml(path, ("a", "b"), CATALOGUE)


def test_the_part_law_is_the_motor_law_split():
    law = part_servo_law(_one_joint())
    assert law.stiffness_Nm_per_rad[0] == pytest.approx(KT * VIN * GAIN * KP / R)
    assert law.effort_Nm[0] == pytest.approx(KT * VIN * MAX_PWM / R)
    assert law.damping_Nms_per_rad[0] == pytest.approx(KT**2 / R + VISCOUS)
    assert (law.armature_kgm2[0], law.frictionloss_Nm[0]) == (ARMATURE, BASE)


PENDULUM = """
<mujoco>
  <option timestep="0.001" gravity="0 0 -9.81" integrator="implicitfast">
    <flag energy="enable"/>
  </option>
  <worldbody>
    <body>
      <joint name="hinge" type="hinge" axis="0 -1 0"/>
      <geom type="sphere" size="0.01" pos="0.25 0 0" mass="0.5"/>
    </body>
  </worldbody>
</mujoco>
"""


def hinge(law, start, gravity=True, xml=PENDULUM):
    """The pendulum (`xml`) with `law`'s joint dynamics, at `start` [rad] (forward pass done),
    without gravity when asked: (model, data)."""
    model = mujoco.MjModel.from_xml_string(xml)
    if not gravity:
        model.opt.gravity[:] = 0.0
    law.set_joint_dynamics(model, np.array([0]))
    data = mujoco.MjData(model)
    data.qpos[0] = start
    mujoco.mj_forward(model, data)
    return model, data


def _pendulum(law, commands, start, gravity=True):
    """The engine's own loop on one hinge: (model, data, loop, energies, viscous heat)."""
    model, data = hinge(law, start, gravity)
    dofs = np.array([0])
    loop = PartLoop(law, model.opt.timestep, np.array([commands[0]]), model, data, dofs)
    energy0 = float(data.energy.sum())
    viscous = 0.0
    for command in commands:
        loop.set_command(np.array([command]))
        data.qfrc_applied[0] = loop.torque(data.qpos[[0]])[0]
        mujoco.mj_step(model, data)
        viscous += VISCOUS * float(data.qvel[0]) ** 2 * model.opt.timestep
    return model, data, loop, float(data.energy.sum()) - energy0, viscous


def test_the_part_law_sags_as_its_static_stiffness_in_mujoco():
    law = dataclasses.replace(
        part_servo_law(_one_joint(dead_band_deg=0)), frictionloss_Nm=np.zeros(1)
    )
    K = KT * VIN * GAIN * KP / R
    sag = brentq(lambda e: K * e - 0.5 * 9.81 * 0.25 * math.cos(e), 0.0, 1.0)
    _, data, _, _, _ = _pendulum(law, np.zeros(4000), 0.0)
    assert -data.qpos[0] == pytest.approx(sag, rel=1e-4)


def test_the_part_law_spins_a_free_joint_at_the_no_load_speed():
    law = dataclasses.replace(
        part_servo_law(_one_joint(dead_band_deg=0)),
        frictionloss_Nm=np.zeros(1),
        damping_Nms_per_rad=np.array([KT**2 / R]),  # back-EMF alone
    )
    _, data, _, _, _ = _pendulum(law, np.full(2000, 1e4), 0.0, gravity=False)
    assert data.qvel[0] == pytest.approx(VIN * MAX_PWM / KT, rel=1e-3)


def test_energy_balance_over_a_swing_to_one_percent():
    """Electrical energy in = I²R + what the motor did to the joint, the latter measured by
    MuJoCo (change of kinetic + potential energy) plus the viscous heat: within 1 %."""
    law = dataclasses.replace(
        part_servo_law(_one_joint(dead_band_deg=0)), frictionloss_Nm=np.zeros(1)
    )
    t = np.arange(0.0, 3.0, 0.001)
    swing = -math.pi / 2 + (math.pi / 2) * 0.5 * (1 - np.cos(np.pi * np.clip(t / 1.5, 0, 1)))
    _, data, loop, delta_mech, viscous = _pendulum(law, swing, -math.pi / 2)
    energy = loop.energy()
    electrical = float(energy.electrical_J[0])
    assert electrical > 0.5  # lifting 0.5 kg by 0.25 m takes ≈ 1.2 J of work, plus heat
    independent = float(energy.joule_J[0]) + delta_mech + viscous
    assert electrical == pytest.approx(independent, rel=0.01)
    # Raised from hanging to (nearly) horizontal: m·g·l·(1 + sin q) + ½·m·l²·q̇².
    q, dq = float(data.qpos[0]), float(data.qvel[0])
    lifted = 0.5 * 9.81 * 0.25 * (1 + math.sin(q)) + 0.5 * 0.5 * 0.25**2 * dq**2
    assert delta_mech == pytest.approx(lifted, rel=1e-3)


def test_a_current_limit_caps_the_current():
    law = dataclasses.replace(
        part_servo_law(_one_joint(current_limit_A=0.5, dead_band_deg=0)),
        frictionloss_Nm=np.zeros(1),
    )
    _, _, loop, _, _ = _pendulum(law, np.full(1000, 1.0), -math.pi / 2)
    assert loop.energy().peak_current_A[0] == pytest.approx(0.5, rel=1e-9)


@pytest.fixture(scope="module")
def robot():
    return load_robot("servo_biped")


def test_servo_biped_stands_on_mx106_parts_and_reports_its_energy(robot):
    traj = run_motion(robot, "com_shift").trajectory
    parts = parts_from_mapping({"servo": "mx106"}, robot.joint_names, CATALOGUE, "servo.toml")
    q_plan = joint_angles(robot, traj.q)
    (result,) = simulate_commands(
        robot,
        traj,
        {"plan": q_plan},
        parts.servo_model(),
        parallel=False,
        law=part_servo_law(parts),
    ).values()
    assert not result.fell, result.fall_reason
    assert result.energy is not None
    energy = result.energy
    assert energy.duration_s == pytest.approx(traj.n_samples * traj.dt, rel=0.02)
    # Holding the robot up costs heat in every loaded joint.
    assert float(energy.joule_J.sum()) > 0.0 and np.all(energy.joule_J >= 0.0)
    assert np.all(energy.peak_current_A <= VIN * MAX_PWM / 2.9649903987776804 + 1e-9)
    assert any("servo parts" in note for note in result.notes)


def test_m6_friction_in_the_loop_follows_its_budget():
    """Holding the arm with BAM's m6 fit: the joint's frictionloss each tick is m6's budget for
    the motor torque kt·I and the external (gravity) torque, and the arm rests inside the band
    that budget leaves around K·e = load."""
    from app.core.servo.motor_law import m6_budget

    parts = _one_joint(dead_band_deg=0, friction_model="m6")
    (part,) = parts.parts
    f = part.friction
    law = part_servo_law(parts)
    assert list(law.m6_joints) == [0]
    model, data, _, _, _ = _pendulum(law, np.zeros(3000), 0.0)
    q = float(data.qpos[0])
    K = part.stiffness_Nm_per_rad  # the m6 fit's kt, R
    assert abs(data.qvel[0]) < 1e-3  # MuJoCo's friction is a soft constraint: a slow creep
    load = 0.5 * 9.81 * 0.25 * math.cos(q)  # gravity's torque pulling the arm down
    motor = K * (-q)  # at rest the motor's torque is the P loop's spring (kt·I, I = V/R)
    budget, _ = m6_budget(f, motor, -load, float(data.qvel[0]))
    assert model.dof_frictionloss[0] == pytest.approx(float(budget), rel=1e-2)
    assert load - budget - 1e-6 <= motor <= load + budget + 1e-6
    m1 = part_servo_law(_one_joint(dead_band_deg=0))
    assert len(m1.m6_joints) == 0


def test_friction_model_is_checked():
    with pytest.raises(ServoPartsError, match="friction_model is 'm9'"):
        _one_joint(friction_model="m9")


def test_the_parts_compensation_inverts_their_quasi_static_model():
    """eq 23 (torque sign) with k = 1/K and φ = b/2 undoes q = q_cmd − τ/K − (b/2)·sign τ."""
    from app.core.servo.compensation import compensated_command
    from app.core.servo.model import servo_response

    parts = parts_from_mapping(
        {"servo": "mx106", "joints": {"b": {"servo": "mx64", "kp": 20}}}, ("a", "b"), CATALOGUE, "x"
    )
    rng = np.random.default_rng(5)
    q = rng.uniform(-0.5, 0.5, (30, 2))
    tau = rng.uniform(-3.0, 3.0, (30, 2))
    q_cmd = compensated_command(q, tau, parts.compensation())
    np.testing.assert_allclose(servo_response(q_cmd, tau, parts.servo_model()), q, atol=1e-12)
    K = np.array([p.stiffness_Nm_per_rad for p in parts.parts])
    b = np.deg2rad([p.dead_band_deg for p in parts.parts])
    np.testing.assert_allclose(q_cmd, q + tau / K + 0.5 * b * np.sign(tau), atol=1e-12)


def test_a_robot_partly_on_parts_runs_each_joint_on_its_own_law(robot):
    """MX-64 parts on the legs' pitch joints, the ideal servo elsewhere: the parts' K is the
    closed form kt·vin·error_gain·kp/R from BAM's constants typed above, the other joints keep
    the virtual servo's law and MuJoCo's own armature, and only the parts draw energy."""
    from app.core.servo.model import ServoModel
    from app.core.simulation.mjcf import SimOptions, build_sim_model
    from app.core.simulation.part_law import law_with_parts
    from app.core.simulation.servo_law import servo_law

    chosen = tuple(n for n in robot.joint_names if "pitch" in n or "knee" in n)
    assert 0 < len(chosen) < robot.n_actuated
    parts = parts_from_mapping({"servo": "mx64"}, chosen, CATALOGUE, "test")
    servo = ServoModel(
        robot.joint_names, np.full(robot.n_actuated, 1.4), np.full(robot.n_actuated, 0.5)
    )
    law = law_with_parts(robot, servo, parts)
    ideal = servo_law(
        servo,
        robot.joint_names,
        [j.effort for j in robot.joints],
        [j.velocity for j in robot.joints],
    )
    mine = np.array([n in chosen for n in robot.joint_names])
    np.testing.assert_allclose(law.stiffness_Nm_per_rad[mine], KT * VIN * GAIN * KP / R)
    np.testing.assert_allclose(law.damping_Nms_per_rad[mine], KT**2 / R + VISCOUS)
    for name in ("stiffness_Nm_per_rad", "half_backlash_rad", "damping_Nms_per_rad", "effort_Nm"):
        np.testing.assert_array_equal(getattr(law, name)[~mine], getattr(ideal, name)[~mine])
    sim = build_sim_model(robot, SimOptions())
    model = mujoco.MjModel.from_xml_string(sim.xml)
    law.set_joint_dynamics(model, sim.actuated_dof)
    armature = model.dof_armature[sim.actuated_dof]
    np.testing.assert_allclose(armature[mine], ARMATURE)
    np.testing.assert_allclose(armature[~mine], SimOptions().armature_kgm2)
    traj = run_motion(robot, "com_shift").trajectory
    (result,) = simulate_commands(
        robot, traj, {"plan": joint_angles(robot, traj.q)}, servo, parallel=False, law=law
    ).values()
    energy = result.energy
    assert energy is not None and not result.fell
    assert np.all(energy.electrical_J[~mine] == 0.0) and np.all(energy.joule_J[~mine] == 0.0)
    assert float(energy.joule_J[mine].sum()) > 0.0
