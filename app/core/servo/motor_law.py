"""A hobby position servo as the part it is: firmware P controller, DC motor, friction.

The model identified by BAM (M. Duclusaud, G. Passault, V. Padois, O. Ly, "Extended Friction
Models for the Physics Simulation of Servo Actuators", 2024/2025; parameters Apache-2.0, see
robots/servos/README.md), per joint, everything at the output shaft:

    duty = clip(error_gain · kp · (q_target − q), −max_pwm, +max_pwm)     firmware P controller
    V    = vin · duty                                                       PWM → voltage
    I    = (V − kt · q̇) / R,  clipped to ±current_limit where one is set     back-EMF, firmware limit
    τ_m  = kt · I                                                           motor torque

and a friction "budget" τ_f ≥ 0 that resists motion (MuJoCo's frictionloss: the torque that
would stop the joint, clipped to ±τ_f) plus viscous damping −friction_viscous · q̇:

    m1:  τ_f = friction_base                                          (Coulomb + viscous)
    m6:  τ_f = friction_base + |τ_e·λ_e − τ_m·λ_m|
               + s·(friction_stribeck + |τ_e·λ_es − τ_m·λ_ms| + quadratic terms),
         s = exp(−|q̇ / dtheta_stribeck|^alpha)     (1 at rest, → 0 moving)

τ_e is the external (load) torque at the joint. The rotor's reflected inertia `armature` adds to
the joint's inertia. Closed forms that follow (tests check the law against them):

    stall torque     τ_s = kt · vin · max_pwm / R   (kt · current_limit if that is lower)
    no-load speed    ω_0 = vin · max_pwm / kt
    static stiffness K   = kt · vin · error_gain · kp / R   [N·m/rad], compliance 1/K

The spring-compensation paper's k [°/(N·m)] is this compliance: a servo's "spring" is its
firmware P gain (MX-64 with the m6 fit: K ≈ 52 N·m/rad, 1/K ≈ 1.1 °/(N·m); the paper's 1.4).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from app.core.errors import StudioError


class MotorLawError(StudioError):
    """Motor or firmware constants that cannot describe a servo."""


@dataclasses.dataclass(frozen=True)
class MotorConstants:
    """The DC motor seen at the output shaft."""

    kt_Nm_per_A: float
    """Torque constant at the output [N·m/A] (also the back-EMF constant [V·s/rad])."""
    R_ohm: float
    """Winding resistance [Ω]."""
    armature_kgm2: float = 0.0
    """Reflected rotor inertia [kg·m²], added to the joint's inertia."""


@dataclasses.dataclass(frozen=True)
class Firmware:
    """The position loop's constants (BAM's firmware table, or the user's settings)."""

    vin_V: float
    """Supply voltage [V]."""
    kp: float
    """Position P gain, in the firmware's own units."""
    error_gain: float
    """Duty cycle per radian of error per unit of kp [1/rad]."""
    max_pwm: float
    """Largest duty cycle (0 … 1]."""
    current_limit_A: float | None = None
    """Firmware current limit [A], None where the firmware sets none."""
    kp_max: float | None = None
    """The largest kp the firmware's control table holds (its P gain register), None where the
    record does not say (app.core.servo.parts.KP_MAX then)."""


@dataclasses.dataclass(frozen=True)
class FrictionM1:
    """BAM's m1: Coulomb budget + viscous damping."""

    friction_base_Nm: float
    friction_viscous_Nms: float
    """[N·m/(rad/s)]."""


@dataclasses.dataclass(frozen=True)
class FrictionM6:
    """BAM's m6: load-dependent, directional, Stribeck, quadratic (names as in BAM's files)."""

    friction_base: float
    friction_stribeck: float
    load_friction_motor: float
    load_friction_external: float
    load_friction_motor_stribeck: float
    load_friction_external_stribeck: float
    load_friction_motor_quad: float
    load_friction_external_quad: float
    dtheta_stribeck: float
    alpha: float
    friction_viscous: float


def check_law(motor: MotorConstants, firmware: Firmware, where: str) -> None:
    """One line naming the first constant that cannot describe a servo."""
    for name, value in (
        ("kt_Nm_per_A", motor.kt_Nm_per_A),
        ("R_ohm", motor.R_ohm),
        ("vin_V", firmware.vin_V),
        ("kp", firmware.kp),
        ("error_gain", firmware.error_gain),
        ("max_pwm", firmware.max_pwm),
    ):
        if not (math.isfinite(value) and value > 0.0):
            raise MotorLawError(f"{where}: {name} is {value}; give a finite number > 0")
    if not (math.isfinite(motor.armature_kgm2) and motor.armature_kgm2 >= 0.0):
        raise MotorLawError(f"{where}: armature_kgm2 is {motor.armature_kgm2}; give one ≥ 0")
    if firmware.max_pwm > 1.0:
        raise MotorLawError(f"{where}: max_pwm is {firmware.max_pwm}; a duty cycle is ≤ 1")
    limit = firmware.current_limit_A
    if limit is not None and not (math.isfinite(limit) and limit > 0.0):
        raise MotorLawError(f"{where}: current_limit_A is {limit}; give a finite number > 0")


def stall_torque_Nm(motor: MotorConstants, firmware: Firmware) -> float:
    """τ_s = kt · vin · max_pwm / R, or kt · current_limit where the firmware caps lower."""
    torque = motor.kt_Nm_per_A * firmware.vin_V * firmware.max_pwm / motor.R_ohm
    if firmware.current_limit_A is not None:
        torque = min(torque, motor.kt_Nm_per_A * firmware.current_limit_A)
    return torque


def datasheet_motor(
    supply_voltage_V: float,
    max_pwm: float,
    stall_torque_Nm: float,
    no_load_speed_rad_s: float,
    armature_kgm2: float,
) -> MotorConstants:
    """The DC motor whose closed forms give a datasheet's stall torque τ_s and no-load speed
    ω_0 at its rated supply V, reached at the firmware's largest duty max_pwm: from
    ω_0 = V·max_pwm/kt and τ_s = kt·V·max_pwm/R,

        kt = V · max_pwm / ω_0,      R = kt · V · max_pwm / τ_s = (V · max_pwm)² / (τ_s · ω_0).

    Friction and the rotor's armature are not published: no friction is modelled (the
    identified servos show a few % of stall), the armature is the caller's."""
    volts = supply_voltage_V * max_pwm
    kt = volts / no_load_speed_rad_s
    return MotorConstants(kt, kt * volts / stall_torque_Nm, armature_kgm2)


def no_load_speed_rad_s(motor: MotorConstants, firmware: Firmware) -> float:
    """ω_0 = vin · max_pwm / kt: where the back-EMF eats the whole supply."""
    return firmware.vin_V * firmware.max_pwm / motor.kt_Nm_per_A


def stiffness_Nm_per_rad(motor: MotorConstants, firmware: Firmware) -> float:
    """K = kt · vin · error_gain · kp / R: torque per radian of error, at rest, unsaturated."""
    return motor.kt_Nm_per_A * firmware.vin_V * firmware.error_gain * firmware.kp / motor.R_ohm


def compliance_deg_per_Nm(motor: MotorConstants, firmware: Firmware) -> float:
    """1/K in the paper's unit [°/(N·m)]: the k that eq 7 compensates."""
    return math.degrees(1.0 / stiffness_Nm_per_rad(motor, firmware))


@dataclasses.dataclass(frozen=True)
class DriveState:
    """What the servo does at one instant (floats or arrays of one shape)."""

    duty: np.ndarray
    voltage_V: np.ndarray
    current_A: np.ndarray
    torque_Nm: np.ndarray


def drive(
    q_target: np.ndarray | float,
    q: np.ndarray | float,
    dq: np.ndarray | float,
    motor: MotorConstants,
    firmware: Firmware,
) -> DriveState:
    """The module docstring's law at one instant: duty, voltage, current, motor torque."""
    error = np.subtract(q_target, q)
    duty = np.clip(firmware.error_gain * firmware.kp * error, -firmware.max_pwm, firmware.max_pwm)
    voltage = firmware.vin_V * duty
    current = (voltage - motor.kt_Nm_per_A * np.asarray(dq, dtype=float)) / motor.R_ohm
    if firmware.current_limit_A is not None:
        current = np.clip(current, -firmware.current_limit_A, firmware.current_limit_A)
    return DriveState(duty, voltage, current, motor.kt_Nm_per_A * current)


def m1_budget(friction: FrictionM1) -> tuple[float, float]:
    """(frictionloss [N·m], damping [N·m·s/rad]) of m1: constant."""
    return friction.friction_base_Nm, friction.friction_viscous_Nms


def m6_budget(
    friction: FrictionM6,
    motor_torque_Nm: np.ndarray | float,
    external_torque_Nm: np.ndarray | float,
    dq: np.ndarray | float,
) -> tuple[np.ndarray, float]:
    """(frictionloss [N·m], damping [N·m·s/rad]) of m6 for the torques and speed given."""
    f = friction
    tau_m = np.asarray(motor_torque_Nm, dtype=float)
    tau_e = np.asarray(external_torque_Nm, dtype=float)
    gearbox = np.abs(tau_e * f.load_friction_external - tau_m * f.load_friction_motor)
    gearbox_stribeck = np.abs(
        tau_e * f.load_friction_external_stribeck - tau_m * f.load_friction_motor_stribeck
    )
    s = np.exp(-(np.abs(np.asarray(dq, dtype=float) / f.dtheta_stribeck) ** f.alpha))
    opposed = np.sign(tau_e) != np.sign(tau_m)
    quadratic = np.where(
        np.abs(tau_e) < np.abs(tau_m),
        f.load_friction_external_quad * tau_e**2,
        np.where(np.abs(tau_e) > np.abs(tau_m), f.load_friction_motor_quad * tau_m**2, 0.0),
    )
    loss = (
        f.friction_base
        + gearbox
        + s * (f.friction_stribeck + gearbox_stribeck + np.where(opposed, quadratic, 0.0))
    )
    return loss, f.friction_viscous


def friction_torque(
    frictionloss_Nm: np.ndarray | float,
    damping_Nms: float,
    dq: np.ndarray | float,
    stopping_torque_Nm: np.ndarray | float,
) -> np.ndarray:
    """The friction torque applied: the torque that would stop the joint this step, clipped to
    ±frictionloss, then viscous −damping·q̇ (BAM's budget as MuJoCo applies frictionloss)."""
    loss = np.asarray(frictionloss_Nm, dtype=float)
    return np.clip(stopping_torque_Nm, -loss, loss) - damping_Nms * np.asarray(dq, dtype=float)
