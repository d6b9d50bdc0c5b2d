"""Servo parts stepped in C (`part_blocks`: MuJoCo's actuators, a block of ticks per
`mujoco.rollout`, energy and current limit checked per tick afterwards) against independent
references:

- on one hinge, the motor law's closed forms (BAM's MX-64 constants typed in
  tests/core/test_servo_parts.py): the sag under a known load is the root of
  K·e = m·g·l·cos(e) with K = kt·vin·error_gain·kp/R, a free joint turns at the no-load speed
  vin·max_pwm/kt, a current limit caps the current at the limit, and over a swing the
  electrical energy equals I²R + the change of MuJoCo's own kinetic + potential energy + the
  viscous heat, to 1 %;
- on servo_biped (one-leg squats, MX-106 parts; held, ramped, and with a current limit the
  robot reaches) and Roban S14 (com shift, MX-106 arms with a current limit and the sized
  ideal servo on the legs, command jumps that the ideal servo's slew spreads over several
  ticks): every recorded column and the energy against the same law ticking in Python
  (`servo_in_mujoco=False`, the per-tick loop the studio ran before).
"""

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
from app.core.servo.parts import parts_from_mapping
from app.core.simulation import part_blocks
from app.core.simulation.engine import run_engine, start
from app.core.simulation.files import sized_servos
from app.core.simulation.part_blocks import PartBlocks
from app.core.simulation.part_law import PartLoop, law_with_parts, part_servo_law
from app.core.simulation.run import prepare
from app.core.simulation.servo_law import Setpoints, actuators_xml
from tests.conftest import ROBAN_URDF
from tests.core.test_servo_parts import PENDULUM as SERVO_PARTS_PENDULUM
from tests.core.test_servo_parts import hinge
from tests.trajectory_slices import first_samples

CATALOGUE = load_catalogue()
# BAM's MX-64 m1 fit and firmware (robots/servos/bam; the figures test_servo_parts.py types).
KT, R = 1.6224667906987444, 3.949433673232461
VISCOUS = 0.011691602145974832
VIN, KP, GAIN, MAX_PWM = 15.0, 32.0, 0.158, 0.9625
MASS, ARM = 0.5, 0.25

PENDULUM = SERVO_PARTS_PENDULUM.replace("</mujoco>", "  {actuators}\n</mujoco>")
"""test_servo_parts' hinge, with the part's actuators in MuJoCo."""


def _mx64(**settings):
    """One hinge's MX-64 law, dead band and Coulomb friction off (the closed forms have none)."""
    parts = parts_from_mapping(
        {"servo": "mx64", "dead_band_deg": 0, **settings}, ("hinge",), CATALOGUE, "test"
    )
    return dataclasses.replace(part_servo_law(parts), frictionloss_Nm=np.zeros(1))


def _hinge(law, start_rad, gravity=True):
    """A hinge on the part's law in MuJoCo's actuators, held by `PartBlocks.hold`."""
    actuators, ctrl_joint = actuators_xml(law, ("hinge",))
    model, data = hinge(law, start_rad, gravity, PENDULUM.format(actuators=actuators))
    zero = np.array([0])
    first = np.zeros(1)
    loop = PartLoop(law, model.opt.timestep, first, model, data, zero)
    setpoints = Setpoints(law, model.opt.timestep, first)
    blocks = PartBlocks(
        model, data, ctrl_joint, 10, setpoints, first[None], (zero, zero), False, loop
    )
    return model, data, loop, blocks


def test_held_in_c_the_part_sags_as_its_static_stiffness():
    _, data, loop, blocks = _hinge(_mx64(), 0.0)
    blocks.hold(np.zeros(1), 4000)
    K = KT * VIN * GAIN * KP / R
    sag = brentq(lambda e: K * e - MASS * 9.81 * ARM * math.cos(e), 0.0, 1.0)
    assert -data.qpos[0] == pytest.approx(sag, rel=1e-4)
    assert loop.limited_ticks == 0


def test_held_in_c_a_free_part_turns_at_the_no_load_speed():
    law = dataclasses.replace(_mx64(), damping_Nms_per_rad=np.array([KT**2 / R]))  # back-EMF
    _, data, _, blocks = _hinge(law, 0.0, gravity=False)
    blocks.hold(np.array([1e4]), 2000)
    assert data.qvel[0] == pytest.approx(VIN * MAX_PWM / KT, rel=1e-3)


def test_a_current_limit_reached_in_a_hold_caps_the_current():
    """The arm sent down from horizontal, then back up while it falls: braking, the motor's
    current would exceed the 0.5 A allowed, so the limit acts (that hold falls back to the law
    in Python), the peak current is the limit, and the arm moves as the per-tick Python loop
    moves it."""
    law = _mx64(current_limit_A=0.5)
    commands = [(-math.pi / 2, 300), (0.0, 700)]
    _, data, loop, blocks = _hinge(law, 0.0)
    for command, ticks in commands:
        blocks.hold(np.array([command]), ticks)
    assert loop.limited_ticks > 0
    assert loop.energy().peak_current_A[0] == pytest.approx(0.5, rel=1e-9)
    model = mujoco.MjModel.from_xml_string(PENDULUM.format(actuators=""))
    law.set_joint_dynamics(model, np.array([0]))
    reference = mujoco.MjData(model)
    mujoco.mj_forward(model, reference)
    python = PartLoop(law, model.opt.timestep, np.zeros(1), model, reference, np.array([0]))
    for command, ticks in commands:
        python.set_command(np.array([command]))
        for _ in range(ticks):
            reference.qfrc_applied[0] = python.torque(reference.qpos[[0]])[0]
            mujoco.mj_step(model, reference)
    assert data.qpos[0] == pytest.approx(reference.qpos[0], abs=1e-12)
    assert python.limited_ticks == loop.limited_ticks


def test_energy_balance_of_a_swing_stepped_in_c_to_one_percent():
    """Electrical energy in = I²R + what the motor did to the joint, the latter measured by
    MuJoCo (change of kinetic + potential energy) plus the viscous heat: within 1 %."""
    model, data, loop, blocks = _hinge(_mx64(), -math.pi / 2)
    energy0 = float(data.energy.sum())
    t = np.arange(0.0, 3.0, 0.001)
    swing = -math.pi / 2 + (math.pi / 2) * 0.5 * (1 - np.cos(np.pi * np.clip(t / 1.5, 0, 1)))
    viscous = 0.0
    for command in swing:  # a hold of one tick per command
        blocks.hold(np.array([command]), 1)
        viscous += VISCOUS * float(data.qvel[0]) ** 2 * model.opt.timestep
    energy = loop.energy()
    delta_mech = float(data.energy.sum()) - energy0
    electrical = float(energy.electrical_J[0])
    assert electrical > 0.5  # lifting 0.5 kg by 0.25 m takes ≈ 1.2 J of work, plus heat
    assert electrical == pytest.approx(float(energy.joule_J[0]) + delta_mech + viscous, rel=0.01)
    q, dq = float(data.qpos[0]), float(data.qvel[0])
    lifted = MASS * 9.81 * ARM * (1 + math.sin(q)) + 0.5 * MASS * ARM**2 * dq**2
    assert delta_mech == pytest.approx(lifted, rel=1e-3)


@pytest.fixture
def python_samples(monkeypatch):
    """How many samples `PartBlocks` stepped in Python and in C, counted as they run."""
    counts = {"python": 0, "c": 0}
    python, c = PartBlocks._python_sample, PartBlocks._record

    def count_python(self, k, recorder):
        counts["python"] += 1
        return python(self, k, recorder)

    def count_c(self, k0, k1, *args):
        counts["c"] += k1 - k0
        return c(self, k0, k1, *args)

    monkeypatch.setattr(part_blocks.PartBlocks, "_python_sample", count_python)
    monkeypatch.setattr(part_blocks.PartBlocks, "_record", count_c)
    return counts


def _same_runs(inp):
    """The run stepped in C and the per-tick Python law's run of the same input agree:
    joint angles to 1e-6 rad, speeds to 1e-4, torques to 1e-4 N·m, sole forces to 1e-3 N
    (the samples' forward passes solve to 1e-10 from different warm starts), the energy
    columns to 1e-6 relative."""
    new = run_engine(inp)
    old = run_engine(dataclasses.replace(inp, servo_in_mujoco=False))
    assert (new.fall_index, new.n_simulated) == (old.fall_index, old.n_simulated)
    np.testing.assert_allclose(new.q, old.q, atol=1e-6)
    np.testing.assert_allclose(new.q_joints_rad, old.q_joints_rad, atol=1e-6)
    np.testing.assert_allclose(new.v, old.v, atol=1e-4)
    np.testing.assert_allclose(new.tau_Nm, old.tau_Nm, atol=1e-4)
    np.testing.assert_allclose(new.contact_force_N, old.contact_force_N, atol=1e-3)
    assert new.energy is not None and old.energy is not None
    for name in ("electrical_J", "joule_J", "mechanical_J", "peak_current_A", "rms_current_A"):
        expected = getattr(old.energy, name)
        scale = max(float(np.abs(expected).max()), 1e-9)
        np.testing.assert_allclose(getattr(new.energy, name), expected, atol=1e-6 * scale)
    assert new.energy.duration_s == pytest.approx(old.energy.duration_s)
    return new


@pytest.fixture(scope="module")
def squats():
    robot = load_robot("servo_biped")
    traj = first_samples(run_motion(robot, "one_leg_squats").trajectory, 300)
    return robot, traj, joint_angles(robot, traj.q)


@pytest.mark.parametrize("case", ["hold", "ramps", "current_limit"])
def test_servo_biped_on_parts_in_c_runs_as_the_per_tick_law(squats, case, python_samples):
    robot, traj, q_cmd = squats
    mapping = {"servo": "mx106"} | ({"current_limit_A": 1.0} if case == "current_limit" else {})
    parts = parts_from_mapping(mapping, robot.joint_names, CATALOGUE, "test")
    law = part_servo_law(parts)
    inp = prepare(robot, traj, q_cmd, parts.servo_model(), law=law)
    inp = dataclasses.replace(inp, linear_hold=case == "ramps")
    assert start(inp)[0].nu > 0  # the part's law is in MuJoCo's actuators
    assert np.any(law.half_backlash_rad > 0.0)  # the two-actuator dead band is exercised
    new = _same_runs(inp)
    if case == "current_limit":  # the robot reaches it: those samples ran in Python
        assert python_samples["python"] > 0 and python_samples["c"] > 0
        assert new.energy is not None
        assert float(new.energy.peak_current_A.max()) == pytest.approx(1.0, rel=1e-9)
    else:  # every sample in C, and the robot stands on its parts
        assert python_samples["python"] == 0 and new.fall_index == -1


def test_roban_s14_partly_on_limited_parts_runs_as_the_per_tick_law(python_samples):
    """MX-106 arms capped at 0.3 A (the ideal servo sized to the robot on legs and waist),
    every 20th command 0.05 rad off (towards the middle of the joint's range): the ideal
    joints' set points slew over several ticks across the samples that fall back to Python
    and back."""
    if not ROBAN_URDF.exists():
        pytest.skip("Roban S14 not in the tests' third-party folder")
    robot = load_robot(str(ROBAN_URDF))
    traj = run_motion(robot, "com_shift").trajectory
    q_cmd = joint_angles(robot, traj.q).copy()
    middle = np.array([0.5 * (joint.lower + joint.upper) for joint in robot.joints])
    q_cmd[10::20] += 0.05 * np.sign(middle - q_cmd[10::20])  # into the joints' ranges
    arms = tuple(name for name in robot.joint_names if name.startswith("zarm"))
    parts = parts_from_mapping({"servo": "mx106", "current_limit_A": 0.3}, arms, CATALOGUE, "test")
    servo = sized_servos(robot)  # Roban falls on the paper's 1.4 °/(N·m) (docs/simulation.md)
    law = law_with_parts(robot, servo, parts)
    assert law is not None and law.has_part is not None and not law.has_part.all()
    assert np.all(np.isfinite(law.velocity_rad_s[~law.has_part]))  # the ideal joints slew
    new = _same_runs(prepare(robot, traj, q_cmd, servo, law=law))
    assert new.fall_index == -1
    assert python_samples["python"] > 0 and python_samples["c"] > 0


def test_m6_friction_stays_in_python():
    """m6's budget follows each tick's constraint forces: no actuators, the per-tick law."""
    robot = load_robot("servo_biped")
    traj = first_samples(run_motion(robot, "com_shift").trajectory, 20)
    parts = parts_from_mapping(
        {"servo": "mx64", "friction_model": "m6"}, robot.joint_names, CATALOGUE, "test"
    )
    law = part_servo_law(parts)
    inp = prepare(robot, traj, joint_angles(robot, traj.q), parts.servo_model(), law=law)
    assert not law.in_mujoco and start(inp)[0].nu == 0
    m1 = part_servo_law(parts_from_mapping({"servo": "mx64"}, robot.joint_names, CATALOGUE, "t"))
    assert m1.in_mujoco
