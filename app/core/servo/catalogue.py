"""The servo catalogue: real servos as parts, one TOML record per servo in robots/servos/.

A record (the same fields for the built-in catalogue and a user's own file)::

    key = "mx64"                      # the name the CLI and servo.toml use
    maker = "ROBOTIS"
    model = "Dynamixel MX-64AT/AR"
    supply_voltage_V = 14.8           # the voltage the figures below are rated at
    stall_torque_Nm = 7.3
    no_load_speed_rpm = 78
    mass_kg = 0.135
    gear_ratio = 200
    backlash_deg = 0.33               # optional: where published
    price = 300.0                     # optional, with price_currency = "USD"
    continuous_torque_Nm = 1.5        # optional: the continuous (thermal) rating, where published
    # A servo rated by a continuous point (Dynamixel-P/PRO: no stall torque published) gives
    # no_load_current_A, continuous_speed_rpm, continuous_current_A and continuous_torque_Nm
    # instead of stall_torque_Nm, and a [drive] table (max_pwm, current_limit_A, p_gain_max):
    # app.core.servo.rated_point derives its motor; it has no kp law (stiffness stated).
    identified = "mx64"               # optional: a BAM-identified model (robots/servos/bam/params)
    [firmware]                        # optional: vin_V, kp, error_gain, max_pwm, current_limit_A,
                                      #   kp_max (the P gain register's top, with its source)
    [motor]                           # optional, the user's own m1 fit: kt_Nm_per_A, R_ohm,
                                      #   armature_kgm2, friction_base_Nm, friction_viscous_Nms
                                      # [firmware] without identified or [motor]: a DC motor
                                      #   derived from the datasheet (motor_law.datasheet_motor)
    [sources]                         # where every figure above comes from, one line each
    stall_torque_Nm = "https://… (Stall Torque 7.3 N·m at 14.8 V)"

A user file holds one record, or several as [[servo]] tables. Missing, negative or non-finite
figures, and a figure without its source, are refused with one line naming the field.
"""

from __future__ import annotations

import dataclasses
import math
import os
from pathlib import Path
from typing import Any

from app.core import input_gate
from app.core.servo import motor_law
from app.core.servo.bam_models import (  # re-exported: the catalogue's public names
    BAM_PARAMS_DIR,
    IdentifiedModel,
    identified_model,
    identified_names,
)
from app.core.servo.motor_law import Firmware, FrictionM1, FrictionM6, MotorConstants
from app.core.servo.rated_point import NO_KP_LAW, RATED_FIGURES, RATED_FIT, RatedPoint, rated_point
from app.core.servo.record_numbers import ServoCatalogueError
from app.core.servo.record_numbers import number_field as _number
from robots.catalogue import ROBOTS_DIR

SERVOS_DIR = ROBOTS_DIR / "servos"

__all__ = [
    "BAM_PARAMS_DIR",
    "NO_KP_LAW",
    "RATED_FIT",
    "SERVOS_DIR",
    "Fit",
    "IdentifiedModel",
    "ServoCatalogueError",
    "ServoRecord",
    "identified_model",
    "identified_names",
    "load_catalogue",
    "read_user_servos",
    "record_from_mapping",
    "records_from_toml",
    "why_not_simulated",
    "with_user_servos",
]

FIGURES = (
    "supply_voltage_V",
    "stall_torque_Nm",
    "no_load_speed_rpm",
    "mass_kg",
    "gear_ratio",
)
"""Datasheet figures every record gives, each > 0 and with its source (a record rated by a
continuous point gives no stall torque: `rated_point`)."""
OPTIONAL_FIGURES = ("backlash_deg", "price", "continuous_torque_Nm")
TEXT_FIELDS = ("key", "maker", "model")
FIRMWARE_FIELDS = ("vin_V", "kp", "error_gain", "max_pwm", "current_limit_A", "kp_max")
MOTOR_FIELDS = (
    "kt_Nm_per_A",
    "R_ohm",
    "armature_kgm2",
    "friction_base_Nm",
    "friction_viscous_Nms",
)
KNOWN_KEYS = (
    *TEXT_FIELDS,
    *FIGURES,
    *OPTIONAL_FIGURES,
    *RATED_FIGURES,
    "price_currency",
    "identified",
    "drive",
    "firmware",
    "motor",
    "sources",
)


@dataclasses.dataclass(frozen=True)
class Fit:
    """An identified motor + friction model: BAM's m1 or m6, or the user's own m1."""

    name: str
    """"m1" or "m6"."""
    motor: MotorConstants
    friction: FrictionM1 | FrictionM6
    derived: str = ""
    """How the fit was made where nothing identified it ("" for BAM's and the user's)."""


@dataclasses.dataclass(frozen=True)
class ServoRecord:
    """One servo of the catalogue (module docstring for the fields)."""

    key: str
    maker: str
    model: str
    supply_voltage_V: float
    stall_torque_Nm: float | None
    """None for a servo rated by a continuous point (its maker publishes no stall torque)."""
    no_load_speed_rpm: float
    mass_kg: float
    gear_ratio: float
    sources: dict[str, str]
    backlash_deg: float | None = None
    price: float | None = None
    price_currency: str | None = None
    continuous_torque_Nm: float | None = None
    """The continuous (thermal) torque rating, where published (sizing assumes a fraction of
    stall otherwise: app.core.servo.sizing)."""
    identified: str | None = None
    firmware: Firmware | None = None
    fits: tuple[Fit, ...] = ()
    """Identified models, simplest first (m1, then m6 where identified)."""
    origin: str = ""
    """The file the record was read from."""
    rated: RatedPoint | None = None
    """The published no-load and continuous points and drive limits (Dynamixel-P/PRO), None
    for a servo rated by its stall torque."""

    @property
    def kp_law(self) -> bool:
        """Whether a firmware kp sets its stiffness (False: no conversion published)."""
        return self.rated is None

    @property
    def no_load_speed_rad_s(self) -> float:
        return self.no_load_speed_rpm * 2.0 * math.pi / 60.0

    def fit(self, name: str | None = None) -> Fit | None:
        """The fit called `name` ("m1", "m6"), or the richest identified; None if none."""
        for fit in reversed(self.fits):
            if name is None or fit.name == name:
                return fit
        return None

    def law(self, fit: str | None = None) -> tuple[MotorConstants, Firmware] | None:
        """The motor (of `fit`, default the richest) and firmware the motor law needs, None
        where either is unknown."""
        chosen = self.fit(fit)
        if self.firmware is None or chosen is None:
            return None
        return chosen.motor, self.firmware

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "key": self.key,
            "maker": self.maker,
            "model": self.model,
            **{name: getattr(self, name) for name in (*FIGURES, *OPTIONAL_FIGURES)},
            "price_currency": self.price_currency,
            "identified": self.identified,
            "sources": dict(self.sources),
            "origin": self.origin,
        }
        firmware = self.firmware
        out["firmware"] = None if firmware is None else dataclasses.asdict(firmware)
        out["fits"] = {}
        for fit in self.fits:
            entry: dict[str, Any] = {"motor": dataclasses.asdict(fit.motor)}
            if fit.derived:
                entry["derived"] = fit.derived
            if firmware is not None:
                motor = fit.motor
                entry["model_stall_torque_Nm"] = motor_law.stall_torque_Nm(motor, firmware)
                entry["model_no_load_speed_rad_s"] = motor_law.no_load_speed_rad_s(motor, firmware)
                entry["stiffness_Nm_per_rad"] = motor_law.stiffness_Nm_per_rad(motor, firmware)
                entry["compliance_deg_per_Nm"] = motor_law.compliance_deg_per_Nm(motor, firmware)
            out["fits"][fit.name] = entry
        out["not_simulated"] = why_not_simulated(self) or None
        out["rated"] = None if self.rated is None else self.rated.to_json()
        out["kp_law"] = None if self.kp_law else NO_KP_LAW
        return out


def _text(data: dict[str, Any], name: str, where: str) -> str:
    value = data.get(name)
    if not isinstance(value, str) or not value.strip():
        raise ServoCatalogueError(f"{where}: {name} is missing; give it as text")
    return value.strip()


def _table(data: dict[str, Any], name: str, where: str) -> dict[str, Any] | None:
    table = data.get(name)
    if table is None:
        return None
    if not isinstance(table, dict):
        raise ServoCatalogueError(f"{where}: {name} must be a [{name}] table")
    return table


def record_from_mapping(data: dict[str, Any], where: str) -> ServoRecord:
    """A checked record: every figure present, finite, positive (backlash and price ≥ 0),
    each with its source; unknown keys refused (a typo would silently drop a figure)."""
    unknown = sorted(set(data) - set(KNOWN_KEYS))
    if unknown:
        raise ServoCatalogueError(
            f"{where}: unknown field(s) {', '.join(unknown)}; known: {', '.join(KNOWN_KEYS)}"
        )
    key = _text(data, "key", where)
    where = f"{where} [{key}]"
    texts = {name: _text(data, name, where) for name in TEXT_FIELDS}
    drive_table = _table(data, "drive", where)
    rated = rated_point(data, drive_table, where)
    required = [n for n in FIGURES if not (rated is not None and n == "stall_torque_Nm")]
    if rated is not None and "stall_torque_Nm" in data:
        raise ServoCatalogueError(
            f"{where}: give stall_torque_Nm or a continuous point with [drive], not both"
        )
    figures = {name: _number(data, name, where, positive=True) for name in required}
    stall = figures.pop("stall_torque_Nm", None)
    optional = {
        name: _number(data, name, where, positive=False)
        for name in OPTIONAL_FIGURES
        if name in data
    }
    sources = _table(data, "sources", where) or {}
    sourced = (*FIGURES, *OPTIONAL_FIGURES, *RATED_FIGURES, "drive", "firmware", "motor", "kp_max")
    odd = sorted(k for k, v in sources.items() if k not in sourced or not isinstance(v, str))
    if odd:
        raise ServoCatalogueError(
            f"{where}: [sources] {odd[0]} is not a figure's source; give text for any of "
            f"{', '.join(sourced)}"
        )
    given = [*required, *optional, *(RATED_FIGURES if rated is not None else ())]
    given += ["drive"] if drive_table is not None else []
    firmware_table = _table(data, "firmware", where)
    motor_table = _table(data, "motor", where)
    given += [name for name, t in (("firmware", firmware_table), ("motor", motor_table)) if t]
    if firmware_table and "kp_max" in firmware_table:
        given.append("kp_max")  # a control table's range: its own source
    for name in given:
        source = sources.get(name)
        if not isinstance(source, str) or not source.strip():
            raise ServoCatalogueError(
                f'{where}: {name} has no source; add {name} = "where the figure comes from" '
                "under [sources]"
            )
    currency = data.get("price_currency")
    if "price" in optional and (not isinstance(currency, str) or not currency.strip()):
        raise ServoCatalogueError(f"{where}: price_currency is missing; say which currency")
    firmware = _firmware(firmware_table, f"{where} firmware") if firmware_table else None
    identified = data.get("identified")
    fits: list[Fit] = []
    if identified is not None:
        if not isinstance(identified, str):
            raise ServoCatalogueError(f"{where}: identified must name a BAM model as text")
        model = identified_model(identified)
        if model.motor is not None:
            fits.append(Fit("m1", model.motor, model.m1))
        if model.m6 is not None and model.m6_motor is not None:
            fits.append(Fit("m6", model.m6_motor, model.m6))
    if motor_table is not None:
        if fits:
            raise ServoCatalogueError(f"{where}: give identified or a [motor] table, not both")
        fits.append(Fit("m1", *_motor(motor_table, f"{where} motor")))
    if rated is not None:
        if firmware_table or fits:
            raise ServoCatalogueError(
                f"{where}: a continuous point's motor is derived from it; give no [firmware], "
                "[motor] or identified beside [drive]"
            )
        motor = rated.motor(DATASHEET_ARMATURE_KGM2)
        fits.append(Fit("m1", motor, FrictionM1(0.0, 0.0), RATED_FIT))
    if firmware is not None and not fits and stall is not None:
        fits.append(_datasheet_fit({**figures, "stall_torque_Nm": stall}, firmware))
    if firmware is not None:
        for fit in fits:
            try:
                motor_law.check_law(fit.motor, firmware, f"{where} {fit.name}")
            except motor_law.MotorLawError as error:
                raise ServoCatalogueError(str(error)) from None
    return ServoRecord(
        key=key,
        maker=texts["maker"],
        model=texts["model"],
        sources={str(k): str(v) for k, v in sources.items()},
        backlash_deg=optional.get("backlash_deg"),
        price=optional.get("price"),
        continuous_torque_Nm=optional.get("continuous_torque_Nm"),
        price_currency=currency if "price" in optional else None,
        identified=identified,
        firmware=firmware,
        fits=tuple(fits),
        origin=where.split(" [")[0],
        rated=rated,
        stall_torque_Nm=stall,
        **figures,
    )


DATASHEET_ARMATURE_KGM2 = 0.01
"""The armature of a servo whose maker publishes none: the simulation's default, the ideal
servo's (app.core.simulation.mjcf.SimOptions.armature_kgm2; BAM's MX-64: 0.012)."""
DATASHEET_FIT = (
    "a DC motor derived from the datasheet's stall torque and no-load speed at its voltage "
    "(kt = V·max_pwm/ω0, R = kt·V·max_pwm/τs); friction and armature are not published: "
    f"no friction, the ideal servo's armature {DATASHEET_ARMATURE_KGM2:g} kg·m²"
)
"""What a fit made by `_datasheet_fit` says of itself."""


def _datasheet_fit(figures: dict[str, float], firmware: Firmware) -> Fit:
    motor = motor_law.datasheet_motor(
        figures["supply_voltage_V"],
        firmware.max_pwm,
        figures["stall_torque_Nm"],
        figures["no_load_speed_rpm"] * 2.0 * math.pi / 60.0,
        DATASHEET_ARMATURE_KGM2,
    )
    return Fit("m1", motor, FrictionM1(0.0, 0.0), DATASHEET_FIT)


def why_not_simulated(record: ServoRecord) -> str:
    """Why the simulation cannot run `record` ("" when it can): it needs the firmware's
    position loop (error_gain, max_pwm, kp), which datasheets do not publish."""
    if record.fit("m1") is not None and (record.firmware is not None or record.rated is not None):
        return ""  # a rated part runs from a servo.toml's stated stiffness (rated_point)
    return (
        "no identified motor model and no firmware constants (error_gain, max_pwm, kp: the "
        "datasheet publishes neither); give [firmware] in your own servo file to simulate it "
        "with a DC motor derived from its stall torque and no-load speed"
    )


def _firmware(table: dict[str, Any], where: str) -> Firmware:
    unknown = sorted(set(table) - set(FIRMWARE_FIELDS))
    if unknown:
        raise ServoCatalogueError(f"{where}: unknown field(s) {', '.join(unknown)}")
    values = {n: _number(table, n, where, positive=True) for n in FIRMWARE_FIELDS[:4]}
    limit = kp_max = None
    if "current_limit_A" in table:
        limit = _number(table, "current_limit_A", where, positive=True)
    if "kp_max" in table:
        kp_max = _number(table, "kp_max", where, positive=True)
        if kp_max < values["kp"]:
            raise ServoCatalogueError(
                f"{where}: kp is {values['kp']:g}, past kp_max {kp_max:g} (the firmware's range)"
            )
    if values["max_pwm"] > 1.0:
        raise ServoCatalogueError(f"{where}: max_pwm is {values['max_pwm']:g}; a duty is ≤ 1")
    return Firmware(current_limit_A=limit, kp_max=kp_max, **values)


def _motor(table: dict[str, Any], where: str) -> tuple[MotorConstants, FrictionM1]:
    unknown = sorted(set(table) - set(MOTOR_FIELDS))
    if unknown:
        raise ServoCatalogueError(f"{where}: unknown field(s) {', '.join(unknown)}")
    kt, r = (_number(table, n, where, positive=True) for n in ("kt_Nm_per_A", "R_ohm"))
    rest = {n: _number(table, n, where, positive=False) for n in MOTOR_FIELDS[2:] if n in table}
    motor = MotorConstants(kt, r, rest.get("armature_kgm2", 0.0))
    friction = FrictionM1(rest.get("friction_base_Nm", 0.0), rest.get("friction_viscous_Nms", 0.0))
    return motor, friction


def load_catalogue(directory: Path = SERVOS_DIR) -> dict[str, ServoRecord]:
    """Every record of the built-in catalogue, by key (a duplicate key is refused)."""
    records: dict[str, ServoRecord] = {}
    for path in sorted(directory.glob("*.toml")):
        data = input_gate.read_toml(path, ServoCatalogueError)
        _add(records, record_from_mapping(data, path.name))
    return records


def read_user_servos(path: str | os.PathLike[str]) -> list[ServoRecord]:
    """The records of a user's TOML file: one record, or several [[servo]] tables."""
    source = os.fspath(path)
    return records_from_toml(input_gate.read_toml(source, ServoCatalogueError), source)


def records_from_toml(data: dict[str, Any], source: str) -> list[ServoRecord]:
    """The records of a user's parsed TOML file named `source` (read_user_servos)."""
    if "servo" in data:
        tables = data["servo"]
        if set(data) != {"servo"} or not isinstance(tables, list) or not tables:
            raise ServoCatalogueError(
                f"{source}: give one record, or [[servo]] tables and nothing beside them"
            )
        records = []
        for i, table in enumerate(tables):
            if not isinstance(table, dict):
                raise ServoCatalogueError(f"{source}: servo {i + 1} is not a table")
            records.append(record_from_mapping(table, f"{source} servo {i + 1}"))
        return records
    return [record_from_mapping(data, source)]


def with_user_servos(
    catalogue: dict[str, ServoRecord], records: list[ServoRecord]
) -> dict[str, ServoRecord]:
    """The catalogue plus the user's records (a key already taken is refused)."""
    merged = dict(catalogue)
    for record in records:
        _add(merged, record)
    return merged


def _add(records: dict[str, ServoRecord], record: ServoRecord) -> None:
    if record.key in records:
        raise ServoCatalogueError(
            f"{record.origin}: key {record.key!r} is already used by "
            f"{records[record.key].origin}; give the servo another key"
        )
    records[record.key] = record
