"""The ideal servo's post hoc energy against closed forms (constant torque and speed)."""

from __future__ import annotations

import numpy as np
import pytest

from app.core.servo.catalogue import load_catalogue
from app.core.simulation.ideal_energy import DefaultMotor, default_motor, ideal_servo_energy


def test_constant_torque_matches_the_closed_form():
    # Joint 0 holds 2 N·m still, joint 1 drives 1.5 N·m at 3 rad/s, joint 2 brakes hard
    # (−4 N·m at 2 rad/s: τ·ω = −8 W against I²R = 16/4·1 = 4 W: nothing drawn, no credit).
    motor = DefaultMotor(np.array([0.5, 1.0, 2.0]), np.array([2.0, 3.0, 1.0]), "test")
    T, dt = 400, 0.0025  # one second
    tau = np.tile([2.0, 1.5, -4.0], (T, 1))
    dq = np.tile([0.0, 3.0, 2.0], (T, 1))
    e = ideal_servo_energy(tau, dq, dt, motor)
    joule = np.array([(2.0 / 0.5) ** 2 * 2.0, 1.5**2 * 3.0, (4.0 / 2.0) ** 2 * 1.0])
    assert e.joule_J == pytest.approx(joule)
    assert e.mechanical_J == pytest.approx([0.0, 4.5, -8.0])
    assert e.positive_work_J == pytest.approx([0.0, 4.5, 0.0])
    assert e.electrical_J == pytest.approx([32.0, 4.5 + 6.75, 0.0])
    assert e.duration_s == pytest.approx(1.0)


def test_the_default_motor_is_the_nearest_identified_servo_geared_to_the_limit():
    catalogue = load_catalogue()
    motor = default_motor(np.array([6.0, 9.5, 0.4]), catalogue)
    mx64, mx106, xl320 = (catalogue[k].fit().motor for k in ("mx64", "mx106", "xl320"))
    assert motor.kt_Nm_per_A == pytest.approx(
        [
            mx64.kt_Nm_per_A * 6.0 / 7.3,
            mx106.kt_Nm_per_A * 9.5 / 10.0,
            xl320.kt_Nm_per_A * 0.4 / 0.39,
        ]
    )
    assert motor.R_ohm == pytest.approx([mx64.R_ohm, mx106.R_ohm, xl320.R_ohm])
    assert "mx64" in motor.text and "mx106" in motor.text


def test_a_held_joint_draws_the_servo_laws_torque_squared_up_to_the_fall():
    # Two joints held still 2° short of their commands: the law's torque is
    # K·(e − b/2) (joint 0, under its limit) and τ_max (joint 1, saturated), constant; no
    # speed, so no mechanical work and no damping. The run falls at 0.5 s of 1 s.
    from types import SimpleNamespace

    from app.core.simulation.ideal_energy import run_ideal_energy
    from app.core.simulation.servo_law import ServoLaw

    law = ServoLaw(
        stiffness_Nm_per_rad=np.array([40.0, 400.0]),
        half_backlash_rad=np.radians([0.25, 0.25]),
        damping_Nms_per_rad=np.array([1.0, 1.0]),
        effort_Nm=np.array([6.0, 6.0]),
        velocity_rad_s=np.array([6.0, 6.0]),
    )
    t = np.arange(101) * 0.01
    q = np.zeros((101, 2))
    result = SimpleNamespace(
        t=t, q_joints_rad=q, v=np.zeros((101, 2)), q_cmd_rad=q + np.radians(2.0),
        fell=True, fall_time_s=0.5, simulated_until_s=1.0,
    )  # fmt: skip
    motor = DefaultMotor(np.array([1.2, 1.2]), np.array([2.0, 2.0]), "test")
    e = run_ideal_energy(result, law, np.array([0, 1]), motor)
    tau = np.array([40.0 * np.radians(1.75), 6.0])
    assert e.duration_s == pytest.approx(0.5)
    assert e.joule_J == pytest.approx((tau / 1.2) ** 2 * 2.0 * 0.5)
    assert e.electrical_J == pytest.approx(e.joule_J)
    assert e.mechanical_J == pytest.approx([0.0, 0.0])
