"""The servo's motor law against its closed forms, BAM's friction models against their
defining equations, and a one-link pendulum in MuJoCo sagging as the static stiffness says."""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np
import pytest
from scipy.optimize import brentq

from app.core.servo import motor_law
from app.core.servo.catalogue import identified_model, load_catalogue
from app.core.servo.motor_law import (
    Firmware,
    FrictionM1,
    MotorConstants,
    drive,
    friction_torque,
    m1_budget,
    m6_budget,
)

# BAM's MX-64 m6 fit and its firmware (shared/actuators/README.md), typed here on purpose.
KT, R, ARMATURE = 1.6016832750318712, 2.3164043271967447, 0.012265893049213158
VIN, KP, GAIN, MAX_PWM = 15.0, 32.0, 0.158, 0.9625
MOTOR = MotorConstants(KT, R, ARMATURE)
FIRMWARE = Firmware(VIN, KP, GAIN, MAX_PWM)


def test_closed_forms_of_the_mx64():
    assert motor_law.stall_torque_Nm(MOTOR, FIRMWARE) == pytest.approx(KT * VIN * MAX_PWM / R)
    assert motor_law.no_load_speed_rad_s(MOTOR, FIRMWARE) == pytest.approx(VIN * MAX_PWM / KT)
    K = KT * VIN * GAIN * KP / R
    assert motor_law.stiffness_Nm_per_rad(MOTOR, FIRMWARE) == pytest.approx(K)
    assert motor_law.compliance_deg_per_Nm(MOTOR, FIRMWARE) == pytest.approx(180 / math.pi / K)
    # The shared README's numbers: K ≈ 52 N·m/rad, ≈ 1.1 °/(N·m).
    assert abs(K - 52.4) < 0.1
    assert math.degrees(1 / K) == pytest.approx(1.09, abs=0.01)


def test_the_law_reaches_its_closed_forms():
    far = 10.0  # rad of error: the duty saturates at max_pwm
    stall = drive(far, 0.0, 0.0, MOTOR, FIRMWARE)
    assert stall.duty == pytest.approx(MAX_PWM)
    assert stall.torque_Nm == pytest.approx(KT * VIN * MAX_PWM / R)
    assert stall.current_A == pytest.approx(VIN * MAX_PWM / R)
    # At the no-load speed the back-EMF eats the whole voltage: no torque.
    free = drive(far, 0.0, VIN * MAX_PWM / KT, MOTOR, FIRMWARE)
    assert free.torque_Nm == pytest.approx(0.0, abs=1e-12)
    # Small errors at rest: torque = K · error (the P loop's spring), both signs.
    errors = np.array([-1e-3, -1e-4, 1e-4, 1e-3])
    small = drive(errors, 0.0, 0.0, MOTOR, FIRMWARE)
    assert small.torque_Nm == pytest.approx(KT * VIN * GAIN * KP / R * errors)
    # A torque–speed line between stall and no-load, as a DC motor's.
    speeds = np.linspace(0.0, VIN * MAX_PWM / KT, 7)
    line = drive(far, 0.0, speeds, MOTOR, FIRMWARE)
    assert line.torque_Nm == pytest.approx(KT * (VIN * MAX_PWM - KT * speeds) / R)


def test_the_firmware_current_limit_caps_the_stall_torque():
    limited = Firmware(VIN, KP, GAIN, MAX_PWM, current_limit_A=1.75)
    assert motor_law.stall_torque_Nm(MOTOR, limited) == pytest.approx(KT * 1.75)
    state = drive(10.0, 0.0, 0.0, MOTOR, limited)
    assert state.current_A == pytest.approx(1.75) and state.torque_Nm == pytest.approx(KT * 1.75)
    # Below the limit the law is unchanged.
    assert drive(1e-4, 0.0, 0.0, MOTOR, limited).torque_Nm == pytest.approx(
        KT * VIN * GAIN * KP / R * 1e-4
    )


def test_m1_friction_is_coulomb_plus_viscous():
    base, viscous = 0.09038677246291783, 0.011691602145974832  # BAM mx64 m1
    model = identified_model("mx64")
    loss, damping = m1_budget(model.m1)
    assert (loss, damping) == (base, viscous)
    # At rest: a stopping torque inside the budget is cancelled exactly (the joint sticks),
    # one outside is clipped to ±friction_base.
    stops = np.array([-0.2, -0.05, 0.0, 0.05, 0.2])
    assert friction_torque(loss, damping, 0.0, stops) == pytest.approx(
        [-base, -0.05, 0.0, 0.05, base]
    )
    # Moving: a large stopping torque opposes the motion; friction = −base·sign(q̇) − c·q̇.
    dq = np.array([-3.0, -0.5, 0.5, 3.0])
    applied = friction_torque(loss, damping, dq, -100.0 * np.sign(dq))
    assert applied == pytest.approx(-base * np.sign(dq) - viscous * dq)


def test_m6_budget_against_its_defining_equation():
    f = identified_model("mx64").m6
    assert f is not None
    # Moving fast, the Stribeck factor vanishes: base + |τe·λe − τm·λm|.
    tau_m, tau_e = 2.0, -1.5
    loss, damping = m6_budget(f, tau_m, tau_e, 1e3)
    expected = f.friction_base + abs(
        tau_e * f.load_friction_external - tau_m * f.load_friction_motor
    )
    assert loss == pytest.approx(expected)
    assert damping == f.friction_viscous
    # At dq = dtheta_stribeck the factor is exactly e^-1 (whatever alpha is).
    loss_vs, _ = m6_budget(f, 0.0, 0.0, f.dtheta_stribeck)
    assert loss_vs == pytest.approx(f.friction_base + math.exp(-1.0) * f.friction_stribeck)
    # At rest, torques opposed, |τe| < |τm|: the quadratic term in τe² is on.
    tau_m, tau_e = 3.0, -1.0
    loss0, _ = m6_budget(f, tau_m, tau_e, 0.0)
    expected0 = (
        f.friction_base
        + abs(tau_e * f.load_friction_external - tau_m * f.load_friction_motor)
        + f.friction_stribeck
        + abs(tau_e * f.load_friction_external_stribeck - tau_m * f.load_friction_motor_stribeck)
        + f.load_friction_external_quad * tau_e**2
    )
    assert loss0 == pytest.approx(expected0)
    # Same signs: no quadratic term.
    loss_same, _ = m6_budget(f, 3.0, 1.0, 0.0)
    assert loss_same == pytest.approx(
        f.friction_base
        + abs(1.0 * f.load_friction_external - 3.0 * f.load_friction_motor)
        + f.friction_stribeck
        + abs(1.0 * f.load_friction_external_stribeck - 3.0 * f.load_friction_motor_stribeck)
    )
    # A constructed speed sequence: the budget falls monotonically from rest.
    speeds = np.linspace(0.0, 10.0, 50)
    budgets, _ = m6_budget(f, np.full(50, 1.0), np.full(50, 0.5), speeds)
    assert np.all(np.diff(budgets) <= 1e-15)


PENDULUM = """
<mujoco>
  <option timestep="0.001" gravity="0 0 -9.81" integrator="implicitfast"/>
  <worldbody>
    <body>
      <joint name="hinge" type="hinge" axis="0 -1 0" armature="{armature}"
             damping="{damping}" frictionloss="{frictionloss}"/>
      <geom type="sphere" size="0.01" pos="{length} 0 0" mass="{mass}"/>
    </body>
  </worldbody>
</mujoco>
"""


def _hold(
    motor: MotorConstants,
    firmware: Firmware,
    target: float,
    mass: float,
    length: float,
    friction: FrictionM1 | None = None,
    gravity: bool = True,
    seconds: float = 4.0,
    start: float | None = None,
) -> tuple[float, float]:
    """A point mass on a hinge driven by the servo law; (final q, final q̇)."""
    loss, damping = (0.0, 0.0) if friction is None else m1_budget(friction)
    model = mujoco.MjModel.from_xml_string(
        PENDULUM.format(
            armature=motor.armature_kgm2,
            damping=damping,
            frictionloss=loss,
            length=length,
            mass=mass,
        )
    )
    if not gravity:
        model.opt.gravity[:] = 0.0
    data = mujoco.MjData(model)
    data.qpos[0] = target if start is None else start
    for _ in range(int(seconds / model.opt.timestep)):
        state = drive(target, data.qpos[0], data.qvel[0], motor, firmware)
        data.qfrc_applied[0] = float(state.torque_Nm)
        mujoco.mj_step(model, data)
    return float(data.qpos[0]), float(data.qvel[0])


def test_pendulum_sags_as_the_static_stiffness_says():
    # Arm commanded horizontal (q = 0 about −y: +q lifts it); gravity pulls it down by the sag e
    # with K·e = m·g·l·cos(e) at rest (no friction): solved here independently of the law.
    mass, length = 0.5, 0.25
    K = KT * VIN * GAIN * KP / R
    sag = brentq(lambda e: K * e - mass * 9.81 * length * math.cos(e), 0.0, 1.0)
    q, dq = _hold(MOTOR, FIRMWARE, 0.0, mass, length)
    assert abs(dq) < 1e-6
    assert -q == pytest.approx(sag, rel=1e-4)
    # ≈ 1.1 °/(N·m) · 1.23 N·m ≈ 1.3°: the compliance the paper's eq 7 compensates.
    assert math.degrees(-q) == pytest.approx(
        motor_law.compliance_deg_per_Nm(MOTOR, FIRMWARE) * mass * 9.81 * length * math.cos(sag),
        rel=1e-4,
    )


def test_with_m1_friction_the_sag_stays_inside_the_friction_band():
    friction = identified_model("mx64").m1
    mass, length = 0.5, 0.25
    K = KT * VIN * GAIN * KP / R
    load = mass * 9.81 * length
    q, _ = _hold(MOTOR, FIRMWARE, 0.0, mass, length, friction)
    lo = (load - friction.friction_base_Nm) / K
    hi = (load + friction.friction_base_Nm) / K
    assert lo - 1e-4 <= -q <= hi + 1e-4


def test_a_free_joint_runs_at_the_no_load_speed():
    # No gravity, no friction, a target far ahead: the duty saturates and the joint
    # accelerates until the back-EMF cancels the supply, at vin·max_pwm/kt.
    _, dq = _hold(MOTOR, FIRMWARE, 1e4, 0.01, 0.05, gravity=False, seconds=2.0, start=0.0)
    assert dq == pytest.approx(VIN * MAX_PWM / KT, rel=1e-4)


def test_catalogue_records_use_the_law_of_their_identified_fit():
    mx64 = load_catalogue()["mx64"]
    law = mx64.law()
    assert law is not None
    motor, firmware = law
    assert (motor, dataclasses.replace(firmware, kp_max=None)) == (MOTOR, FIRMWARE)
    assert firmware.kp_max == 254  # the MX P Gain register's range, 0 … 254 (e-Manual)
    m1_motor, _ = mx64.law("m1") or (None, None)
    assert m1_motor == identified_model("mx64").motor
