"""Servos rated by a continuous point, not a stall torque (ROBOTIS Dynamixel-P / PRO).

Their pages publish, at the supply voltage V: the no-load speed ω_0 and current I_0, and one
continuous operating point (speed ω_c, torque τ_c, current I_c); no stall torque. The control
table gives the firmware's largest duty (PWM Limit) and current (Current Limit register's
range), and the Position P Gain register's range, but no conversion of that gain to duty per
radian (the X series publishes K_PP = K_PP(TBL)/128; the P series' table gives the range only).

The motor at the output, from the two published points on the DC motor line
τ = (kt/R)·(V·max_pwm − kt·ω) (the motor law's, `motor_law`):

    kt = V·max_pwm / ω_0                  (back-EMF: the whole supply at no-load speed)
    D  = kt²/R = τ_c / (ω_0 − ω_c)        (the line's slope through the continuous point)
    R  = kt² / D = kt²·(ω_0 − ω_c) / τ_c

so the line's stall torque kt·V·max_pwm/R = D·ω_0 is an extrapolation the maker never rates,
and is not the peak. The peak is bounded by the firmware's current limit I_lim (the register's
largest value): τ_lim = (τ_c / I_c)·I_lim, the torque per ampere of the published continuous
point (its no-load current and gearbox losses included: the smaller of the readings of the
page, τ_c/I_c < τ_c/(I_c − I_0)), a stated derived limit. The model's own current at that
torque, τ_lim/kt, is the current limit the simulation applies, so its torque clips at τ_lim.
Thermal (RMS) sizing uses the published τ_c. Friction and the rotor's armature are not
published: none is modelled and the armature is the ideal servo's (as for datasheet fits); the
model's current at the continuous point, τ_c/kt, is below the published I_c (no no-load current,
no gearbox loss in it), so its I²R understates the part's heat.

With no conversion of the P gain, these parts have no kp law: a servo.toml gives each joint's
stiffness K [N·m/rad] (`stiffness_Nm_per_rad`), the P loop the simulation runs is
duty = clip(K·R/(kt·V)·e, ±max_pwm) (so K = kt·V·error_gain·kp/R holds with kp = K and
error_gain = R/(kt·V)), and the sizing states the K each joint needs rather than a kp.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

from app.core.servo.motor_law import Firmware, MotorConstants
from app.core.servo.record_numbers import ServoCatalogueError
from app.core.servo.record_numbers import number_field as _number

RATED_FIGURES = ("no_load_current_A", "continuous_speed_rpm", "continuous_current_A")
"""The continuous point's figures beside continuous_torque_Nm (each with its source)."""
DRIVE_FIELDS = ("max_pwm", "current_limit_A", "p_gain_max")
"""A [drive] table: the control table's largest duty, current limit and P gain register."""
RATED_FIT = (
    "a DC motor through the published no-load speed and continuous point at the rated voltage "
    "(kt = V·max_pwm/ω0, R = kt²·(ω0 − ωc)/τc); peak torque capped at τc/Ic × the firmware's "
    "current limit; no friction, the ideal servo's armature; no kp law (stiffness stated)"
)
"""What a fit made from a continuous point says of itself."""
NO_KP_LAW = (
    "no kp law: the maker publishes the Position P Gain register's range but no conversion "
    "to duty per radian, so a servo.toml gives its stiffness_Nm_per_rad (size --servo-toml "
    "writes the K each joint needs); the studio's kp cannot set it"
)


@dataclasses.dataclass(frozen=True)
class RatedPoint:
    """A servo's published no-load and continuous points and its drive's limits."""

    supply_voltage_V: float
    no_load_speed_rpm: float
    no_load_current_A: float
    continuous_speed_rpm: float
    continuous_torque_Nm: float
    continuous_current_A: float
    max_pwm: float
    """The firmware's largest duty (PWM Limit register's top)."""
    current_limit_A: float
    """The firmware's largest current (Current Limit register's top) [A]."""
    p_gain_max: float
    """The Position P Gain register's top (its conversion is not published)."""

    @property
    def no_load_speed_rad_s(self) -> float:
        return self.no_load_speed_rpm * 2.0 * math.pi / 60.0

    @property
    def continuous_speed_rad_s(self) -> float:
        return self.continuous_speed_rpm * 2.0 * math.pi / 60.0

    @property
    def kt_Nm_per_A(self) -> float:
        """V·max_pwm/ω_0 [N·m/A] (= the back-EMF constant [V·s/rad])."""
        return self.supply_voltage_V * self.max_pwm / self.no_load_speed_rad_s

    @property
    def back_emf_Nms_per_rad(self) -> float:
        """D = τ_c/(ω_0 − ω_c): the motor line's slope."""
        return self.continuous_torque_Nm / (self.no_load_speed_rad_s - self.continuous_speed_rad_s)

    @property
    def R_ohm(self) -> float:
        return self.kt_Nm_per_A**2 / self.back_emf_Nms_per_rad

    @property
    def line_stall_torque_Nm(self) -> float:
        """Where the line meets ω = 0: D·ω_0 (extrapolated; not a rating)."""
        return self.back_emf_Nms_per_rad * self.no_load_speed_rad_s

    @property
    def torque_limit_Nm(self) -> float:
        """τ_c/I_c × the firmware's current limit: the peak this record allows."""
        return self.continuous_torque_Nm / self.continuous_current_A * self.current_limit_A

    @property
    def model_current_limit_A(self) -> float:
        """τ_lim/kt: the model's current at the torque limit (the simulation's limit)."""
        return self.torque_limit_Nm / self.kt_Nm_per_A

    def motor(self, armature_kgm2: float) -> MotorConstants:
        return MotorConstants(self.kt_Nm_per_A, self.R_ohm, armature_kgm2)

    def firmware(
        self,
        stiffness_Nm_per_rad: float,
        vin_V: float | None = None,
        current_limit_A: float | None = None,
    ) -> Firmware:
        """The P loop that gives `stiffness_Nm_per_rad` at `vin_V` (default the rated voltage):
        kp = K and error_gain = R/(kt·vin), so that kt·vin·error_gain·kp/R = K. The current
        limit: the firmware's `current_limit_A` (default its register's top), as the model's
        current at the torque it allows, (τ_c/I_c)·I/kt."""
        vin = self.supply_voltage_V if vin_V is None else vin_V
        limit = self.current_limit_A if current_limit_A is None else current_limit_A
        per_amp = self.continuous_torque_Nm / self.continuous_current_A
        return Firmware(
            vin_V=vin,
            kp=stiffness_Nm_per_rad,
            error_gain=self.R_ohm / (self.kt_Nm_per_A * vin),
            max_pwm=self.max_pwm,
            current_limit_A=per_amp * limit / self.kt_Nm_per_A,
        )

    def to_json(self) -> dict[str, float]:
        return {
            **dataclasses.asdict(self),
            "kt_Nm_per_A": self.kt_Nm_per_A,
            "R_ohm": self.R_ohm,
            "back_emf_Nms_per_rad": self.back_emf_Nms_per_rad,
            "line_stall_torque_Nm": self.line_stall_torque_Nm,
            "torque_limit_Nm": self.torque_limit_Nm,
            "model_current_limit_A": self.model_current_limit_A,
        }


def rated_point(
    data: dict[str, Any], drive: dict[str, Any] | None, where: str
) -> RatedPoint | None:
    """The record's continuous point and [drive] table, checked (None where it gives none):
    every figure finite and > 0, the continuous point below no-load speed, the drive's duty ≤ 1
    and its current limit above the continuous current."""
    given = [name for name in (*RATED_FIGURES, "continuous_torque_Nm") if name in data]
    if not any(name in data for name in RATED_FIGURES) and drive is None:
        return None
    if drive is None:
        raise ServoCatalogueError(
            f"{where}: a continuous point needs a [drive] table ({', '.join(DRIVE_FIELDS)})"
        )
    unknown = sorted(set(drive) - set(DRIVE_FIELDS))
    if unknown:
        raise ServoCatalogueError(f"{where} drive: unknown field(s) {', '.join(unknown)}")
    missing = [n for n in (*RATED_FIGURES, "continuous_torque_Nm") if n not in given]
    if missing:
        raise ServoCatalogueError(f"{where}: {missing[0]} is missing (the continuous point)")
    figures = {n: _number(data, n, where, positive=True) for n in given}
    limits = {n: _number(drive, n, f"{where} drive", positive=True) for n in DRIVE_FIELDS}
    if limits["max_pwm"] > 1.0:
        raise ServoCatalogueError(f"{where} drive: max_pwm is {limits['max_pwm']:g}; a duty is ≤ 1")
    point = RatedPoint(
        supply_voltage_V=_number(data, "supply_voltage_V", where, positive=True),
        no_load_speed_rpm=_number(data, "no_load_speed_rpm", where, positive=True),
        **figures,
        **limits,
    )
    if point.continuous_speed_rpm >= point.no_load_speed_rpm:
        raise ServoCatalogueError(
            f"{where}: continuous_speed_rpm {point.continuous_speed_rpm:g} must be below "
            f"no_load_speed_rpm {point.no_load_speed_rpm:g}"
        )
    if point.continuous_current_A <= point.no_load_current_A:
        raise ServoCatalogueError(
            f"{where}: continuous_current_A {point.continuous_current_A:g} must exceed "
            f"no_load_current_A {point.no_load_current_A:g}"
        )
    if point.current_limit_A < point.continuous_current_A:
        raise ServoCatalogueError(
            f"{where} drive: current_limit_A {point.current_limit_A:g} is below the continuous "
            f"current {point.continuous_current_A:g}"
        )
    return point
