"""Eq 7 on the servo's drive torque (`drive_torque_Nm`): a moving joint follows its plan.

The reference is the servo law itself (`app/core/simulation/servo_law.py`, its docstring's
equations), integrated here on one joint by semi-implicit Euler at 0.1 ms, independently of
MuJoCo: τ_spring = K·(q_cmd − q), J·q̈ = τ_spring − D·q̇ − τ_load. Its closed forms: at a
constant speed ω the joint lags the command by c·D·ω; with q_cmd = q + c·(τ + D·q̇ + J·q̈) it
follows q exactly (the spring's torque is then what the rotor and the load need).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from app.core.servo.compensation import CompensationError, drive_torque_Nm

C_DEG = 1.4  # servo_biped's virtual servo [°/(N·m)]
K = 1.0 / math.radians(C_DEG)  # [N·m/rad]
D = 1.0  # back-EMF damping [N·m·s/rad]
J = 0.01  # rotor inertia [kg·m²]


def _servo_follows(q_cmd, t, q0, qd0, tau_load, h=1e-4):
    """Integrate J·q̈ = K·(q_cmd(t) − q) − D·q̇ − τ_load(t), commands interpolated linearly."""
    q, qd, out = q0, qd0, []
    steps = round((t[-1] - t[0]) / h)
    for i in range(steps + 1):
        ti = t[0] + i * h
        if i % round((t[1] - t[0]) / h) == 0:
            out.append(q)
        s = np.interp(ti, t, q_cmd)
        qdd = (K * (s - q) - D * qd - np.interp(ti, t, tau_load)) / J
        qd += h * qdd
        q += h * qd
    return np.array(out[: len(t)])


def test_a_joint_at_constant_speed_lags_by_c_D_omega_and_the_drive_term_removes_it():
    omega = 3.0  # [rad/s], a swing hip's speed in a walk
    t = np.arange(0.0, 1.0 + 1e-9, 1e-3)
    q_plan = omega * t
    zero = np.zeros_like(t)
    plain = _servo_follows(q_plan, t, 0.0, omega, zero)
    lag = q_plan[-1] - plain[-1]
    assert lag == pytest.approx(math.radians(C_DEG) * D * omega, rel=1e-3)  # c·D·ω
    tau = drive_torque_Nm(zero[:, None], np.full((len(t), 1), omega), zero[:, None], D, J)
    q_cmd = q_plan + math.radians(C_DEG) * tau[:, 0]
    followed = _servo_follows(q_cmd, t, 0.0, omega, zero)
    assert abs(q_plan[-1] - followed[-1]) < 1e-3 * lag


def test_a_loaded_swinging_joint_follows_its_plan_with_the_drive_torque_only():
    # q = A sin(2π f t) under a load torque, from rest on the plan: eq 7 on τ alone leaves the
    # damping and inertia lag; eq 7 on τ + D·q̇ + J·q̈ follows to the integrator's accuracy.
    a, f = 0.4, 2.5
    t = np.arange(0.0, 1.2 + 1e-9, 1e-3)
    w = 2 * math.pi * f
    q = a * np.sin(w * t)
    qd = a * w * np.cos(w * t)
    qdd = -a * w * w * np.sin(w * t)
    load = 2.0 + 0.5 * np.sin(3 * t)  # [N·m]
    c = math.radians(C_DEG)
    eq7 = _servo_follows(q + c * load, t, 0.0, a * w, load)
    tau = drive_torque_Nm(load[:, None], qd[:, None], qdd[:, None], D, J)[:, 0]
    driven = _servo_follows(q + c * tau, t, 0.0, a * w, load)
    err_eq7 = np.abs(eq7 - q).max()
    err_driven = np.abs(driven - q).max()
    assert err_eq7 > math.radians(5.0)  # the lag c·D·a·ω ≈ 0.38 rad is not small
    assert err_driven < 2e-3 * err_eq7


def test_shapes_are_checked():
    with pytest.raises(CompensationError, match="one value per sample and joint"):
        drive_torque_Nm(np.zeros((3, 2)), np.zeros((3, 1)), np.zeros((3, 2)), 1.0, 0.0)
