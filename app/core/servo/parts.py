"""A servo per joint: catalogue servos and their firmware settings, read from a servo.toml.

    servo = "mx106"              # every joint not given its own (optional)
    kp = 32                      # firmware settings for every joint (optional; default the
    vin_V = 15.0                 #   record's [firmware]: BAM's constants)
    current_limit_A = 3.0
    dead_band_deg = 0.33         # default the record's published backlash, else 0
    friction_model = "m6"        # "m1" (default: Coulomb + viscous) or "m6" where identified
    [joints.left_knee]
    servo = "mx64"
    kp = 40

Every actuated joint needs a servo whose record carries an identified motor model and firmware
constants (the motor law needs kt, R and error_gain); each value is checked, one line naming the
field. A servo rated by a continuous point (Dynamixel-P/PRO, app.core.servo.rated_point) has no
kp law: its joint gives `stiffness_Nm_per_rad = 1200` instead of kp (a kp in its table is
refused; a kp for every joint applies to the others), and runs the P loop with that stiffness. The part's stiffness K = kt·vin·error_gain·kp/R gives the compliance 1/K that the
quasi-static servo model and eq 7 use (`ServoParts.servo_model`).
"""

from __future__ import annotations

import dataclasses
import math
import os
from collections.abc import Sequence
from typing import Any

import numpy as np

from app.core import input_gate
from app.core.errors import StudioError, refuse_unknown_joints
from app.core.servo import motor_law
from app.core.servo.catalogue import ServoRecord, why_not_simulated
from app.core.servo.compensation import CompensationParams
from app.core.servo.model import ServoModel
from app.core.servo.motor_law import Firmware, FrictionM1, FrictionM6, MotorConstants

SETTINGS = ("kp", "vin_V", "current_limit_A", "dead_band_deg", "stiffness_Nm_per_rad")
FRICTION_MODELS = ("m1", "m6")
KP_MAX = 16383.0
"""The largest position P gain a Dynamixel control table holds (X series, 2 bytes)."""
MAX_DEAD_BAND_DEG = 10.0


class ServoPartsError(StudioError):
    """A servo.toml that names servos the studio cannot simulate, or bad firmware settings."""


def is_parts_file(data: dict[str, Any]) -> bool:
    """A servo.toml that names catalogue servos (rather than a virtual compliance)."""
    joints = data.get("joints")
    tables = joints.values() if isinstance(joints, dict) else ()
    return "servo" in data or any(isinstance(t, dict) and "servo" in t for t in tables)


@dataclasses.dataclass(frozen=True)
class JointPart:
    """The servo of one joint with its firmware settings."""

    joint: str
    servo: str
    """Catalogue key."""
    motor: MotorConstants
    firmware: Firmware
    friction: FrictionM1 | FrictionM6
    """BAM's m1 or m6 fit, with `motor` the same fit's kt, R, armature."""
    dead_band_deg: float
    mass_kg: float
    kp_law: bool = True
    """False for a part rated by a continuous point: firmware.kp then holds its stated
    stiffness [N·m/rad] (app.core.servo.rated_point)."""

    @property
    def stiffness_Nm_per_rad(self) -> float:
        return motor_law.stiffness_Nm_per_rad(self.motor, self.firmware)

    @property
    def compliance_deg_per_Nm(self) -> float:
        return motor_law.compliance_deg_per_Nm(self.motor, self.firmware)

    @property
    def stall_torque_Nm(self) -> float:
        return motor_law.stall_torque_Nm(self.motor, self.firmware)


@dataclasses.dataclass(frozen=True)
class ServoParts:
    """One part per actuated joint, in the robot's joint order."""

    parts: tuple[JointPart, ...]

    @property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(p.joint for p in self.parts)

    def servo_model(self) -> ServoModel:
        """The quasi-static servos these parts are: compliance 1/K, dead band as backlash."""
        return ServoModel(
            self.joint_names,
            np.array([p.compliance_deg_per_Nm for p in self.parts]),
            np.array([p.dead_band_deg for p in self.parts]),
        )

    def compensation(self) -> CompensationParams:
        """Eq 23 with the torque sign, k = 1/K and φ = half the dead band: the exact inverse of
        `servo_model` (the compensation that follows from the parts and their kp)."""
        return CompensationParams(
            self.joint_names,
            np.array([p.compliance_deg_per_Nm for p in self.parts]),
            np.array([0.5 * p.dead_band_deg for p in self.parts]),
            np.ones(len(self.parts), dtype=bool),
            clearance_sign="torque",
            notes=("k = 1/K of each joint's servo part, φ = half its dead band",),
        )

    def to_json(self) -> list[dict[str, Any]]:
        return [
            {
                "joint": p.joint,
                "servo": p.servo,
                "kp": p.firmware.kp if p.kp_law else None,
                "vin_V": p.firmware.vin_V,
                "current_limit_A": p.firmware.current_limit_A,
                "dead_band_deg": p.dead_band_deg,
                "friction_model": "m6" if isinstance(p.friction, FrictionM6) else "m1",
                "stiffness_Nm_per_rad": p.stiffness_Nm_per_rad,
                "compliance_deg_per_Nm": p.compliance_deg_per_Nm,
                "stall_torque_Nm": p.stall_torque_Nm,
            }
            for p in self.parts
        ]


def _setting(table: dict[str, Any], name: str, where: str) -> float | None:
    if name not in table:
        return None
    value = table[name]
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ServoPartsError(f"{where}: {name} is {value!r}; give a finite number")
    value = float(value)
    if name == "dead_band_deg":
        if not 0.0 <= value <= MAX_DEAD_BAND_DEG:
            raise ServoPartsError(f"{where}: {name} is {value:g}; give 0 … {MAX_DEAD_BAND_DEG:g}°")
    elif value <= 0.0:
        raise ServoPartsError(f"{where}: {name} is {value:g}; it must be > 0")
    if name == "kp" and value > KP_MAX:
        raise ServoPartsError(
            f"{where}: kp is {value:g}, outside the firmware's range 0 … {KP_MAX:g}"
        )
    return value


def _friction_model(table: dict[str, Any], where: str, default: str) -> str:
    value = table.get("friction_model", default)
    if value not in FRICTION_MODELS:
        raise ServoPartsError(
            f"{where}: friction_model is {value!r}; give one of {', '.join(FRICTION_MODELS)}"
        )
    return str(value)


def _part(
    joint: str,
    key: str,
    settings: dict[str, float],
    catalogue: dict[str, ServoRecord],
    where: str,
    friction_model: str = "m1",
    own: set[str] | frozenset[str] = frozenset(),
) -> JointPart:
    """`key`'s part on `joint`; `own`: the settings the joint's own table gives (a kp or a
    stiffness for all joints applies to the parts it fits; in a joint's table it must fit)."""
    record = catalogue.get(key)
    if record is None:
        raise ServoPartsError(
            f"{where}: servo {key!r} is not in the catalogue; known: {', '.join(sorted(catalogue))}"
        )
    if not record.kp_law:
        return _stated_part(joint, record, settings, where, friction_model, "kp" in own)
    if "stiffness_Nm_per_rad" in own:
        raise ServoPartsError(
            f"{where}: {key} has a kp law: give kp, not stiffness_Nm_per_rad (that is for "
            "servos rated by a continuous point)"
        )
    fit = record.fit(friction_model)
    base = record.firmware
    if base is None or why_not_simulated(record):
        why = why_not_simulated(record)
        raise ServoPartsError(f"{where}: servo {key!r} cannot be simulated: {why}")
    if fit is None:
        raise ServoPartsError(f"{where}: servo {key!r} has no identified {friction_model} model")
    firmware = Firmware(
        vin_V=settings.get("vin_V", base.vin_V),
        kp=settings.get("kp", base.kp),
        error_gain=base.error_gain,
        max_pwm=base.max_pwm,
        current_limit_A=settings.get("current_limit_A", base.current_limit_A),
        kp_max=base.kp_max,
    )
    kp_max = KP_MAX if base.kp_max is None else base.kp_max
    if firmware.kp > kp_max:
        raise ServoPartsError(
            f"{where}: kp is {firmware.kp:g}, outside {key}'s firmware range 0 … {kp_max:g}"
        )
    try:
        motor_law.check_law(fit.motor, firmware, where)
    except motor_law.MotorLawError as error:
        raise ServoPartsError(str(error)) from None
    dead_band = settings.get("dead_band_deg", record.backlash_deg or 0.0)
    return JointPart(joint, key, fit.motor, firmware, fit.friction, dead_band, record.mass_kg)


def _stated_part(
    joint: str,
    record: ServoRecord,
    settings: dict[str, float],
    where: str,
    friction_model: str,
    own_kp: bool,
) -> JointPart:
    """The part of a servo rated by a continuous point, at the stiffness its table states."""
    rated, fit = record.rated, record.fit("m1")
    if rated is None or fit is None:
        raise ServoPartsError(f"{where}: servo {record.key!r} cannot be simulated")
    if friction_model != "m1":
        raise ServoPartsError(f"{where}: servo {record.key!r} has no identified {friction_model}")
    stiffness = settings.get("stiffness_Nm_per_rad")
    if stiffness is None or own_kp:
        raise ServoPartsError(
            f"{where}: {record.key} has no kp law (rated by a continuous point): give "
            "stiffness_Nm_per_rad = <N·m/rad> for this joint, not kp"
        )
    limit = settings.get("current_limit_A")
    if limit is not None and limit > rated.current_limit_A:
        raise ServoPartsError(
            f"{where}: current_limit_A is {limit:g}, past {record.key}'s register's "
            f"{rated.current_limit_A:g} A"
        )
    firmware = rated.firmware(stiffness, settings.get("vin_V"), limit)
    try:
        motor_law.check_law(fit.motor, firmware, where)
    except motor_law.MotorLawError as error:
        raise ServoPartsError(str(error)) from None
    dead_band = settings.get("dead_band_deg", record.backlash_deg or 0.0)
    return JointPart(
        joint, record.key, fit.motor, firmware, fit.friction, dead_band, record.mass_kg, False
    )


def parts_from_mapping(
    data: dict[str, Any],
    joint_names: Sequence[str],
    catalogue: dict[str, ServoRecord],
    source: str,
) -> ServoParts:
    """Checked parts for every joint of `joint_names` (module docstring)."""
    unknown = set(data) - {"servo", "joints", "friction_model", *SETTINGS}
    if unknown:
        raise ServoPartsError(
            f"{source}: unknown key(s) {', '.join(sorted(unknown))}; expected servo, "
            f"{', '.join(SETTINGS)} and [joints.<name>] tables"
        )
    joints = data.get("joints", {})
    if not isinstance(joints, dict):
        raise ServoPartsError(f"{source}: [joints] must be tables [joints.<name>]")
    refuse_unknown_joints(joints, joint_names, ServoPartsError, where=source)
    default_servo = data.get("servo")
    if default_servo is not None and not isinstance(default_servo, str):
        raise ServoPartsError(f"{source}: servo must be a catalogue key, as text")
    defaults = {n: v for n in SETTINGS if (v := _setting(data, n, source)) is not None}
    default_friction = _friction_model(data, source, "m1")
    without = [
        name
        for name in joint_names
        if default_servo is None and not isinstance(joints.get(name, {}).get("servo"), str)
    ]
    if without:
        raise ServoPartsError(
            f"{source}: {len(without)} joint(s) without a servo, first {without[0]}; give "
            'servo = "<key>" at the top or in [joints.<name>]'
        )
    parts = []
    for name in joint_names:
        table = joints.get(name, {})
        where = f"{source} [joints.{name}]" if name in joints else source
        if not isinstance(table, dict) or set(table) - {"servo", "friction_model", *SETTINGS}:
            raise ServoPartsError(
                f"{where}: a joint's table takes servo, friction_model and "
                f"{', '.join(SETTINGS)} only"
            )
        settings = dict(defaults)
        own = {n: v for n in SETTINGS if (v := _setting(table, n, where)) is not None}
        settings.update(own)
        key = table.get("servo", default_servo)
        friction = _friction_model(table, where, default_friction)
        parts.append(_part(name, str(key), settings, catalogue, where, friction, set(own)))
    return ServoParts(tuple(parts))


def read_parts_toml(
    path: str | os.PathLike[str],
    joint_names: Sequence[str],
    catalogue: dict[str, ServoRecord],
) -> ServoParts:
    """`parts_from_mapping` of a servo.toml file (size, encoding, TOML and values checked)."""
    source = os.fspath(path)
    data = input_gate.read_toml(source, ServoPartsError)
    return parts_from_mapping(data, joint_names, catalogue, source)
