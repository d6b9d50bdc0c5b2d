"""Servo parts as sweep parameters: which catalogue servo the leg joints get (categorical) and
its firmware kp (discrete), swept or fixed for every point.

    [part]                      # fixed for every point (needs simulate = true)
    servo = "mx106"             # a catalogue servo the simulation can run
    kp = 32                     # optional: the firmware's P gain (default: the record's)

    [[parameter]]
    name = "servo"
    kind = "part"
    choices = ["mx64", "mx106"] # categorical: each point takes one (a grid takes each)

    [[parameter]]
    name = "kp"
    kind = "part"
    min = 16
    max = 64                    # whole numbers (the firmware's register)
    levels = 3

With a part, every leg joint (those the uniform preset compensates) runs the part's motor law
in the simulation (app.core.simulation.part_law; the other joints stay rigid), and
compensation on is eq 7 with k = 1/K of the part and its kp (K = kt·vin·error_gain·kp/R), its
dead band the record's backlash unless the sweep gives dead_band_deg. A categorical value is
stored as the index of its choice (the results tables and the studio show the servo's key).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import Any

from app.core.sweeps.robot_variants import SweepSpecError

PART_NAMES = ("servo", "kp")
"""The part parameters a sweep can vary (kind = "part") or fix ([part])."""
MAX_CHOICES = 64


@functools.cache
def runnable_servos() -> dict[str, Any]:
    """The built-in catalogue's servos the simulation can run (a motor model and firmware)."""
    from app.core.servo.catalogue import load_catalogue
    from app.core.servo.choice import simulatable

    return simulatable(load_catalogue())


def check_servo(key: Any, where: str) -> str:
    """`key` if it names a servo the simulation can run; SweepSpecError naming the ones it can."""
    servos = runnable_servos()
    if not isinstance(key, str) or key not in servos:
        raise SweepSpecError(
            f"{where}: servo {key!r} is not a catalogue servo the simulation can run; give one "
            f"of {', '.join(sorted(servos))}"
        )
    return key


def check_kp(value: Any, where: str) -> float:
    from app.core.servo.parts import KP_MAX

    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise SweepSpecError(f"{where}: kp = {value!r}; give a finite number")
    if not 1.0 <= value <= KP_MAX:
        raise SweepSpecError(f"{where}: kp = {value:g}; the firmware's range is 1 … {KP_MAX:g}")
    return float(value)


def choices_of(entry: dict[str, Any], where: str) -> tuple[str, ...]:
    """The checked `choices` of a categorical servo parameter."""
    raw = entry.get("choices")
    if not isinstance(raw, list) or not raw:
        raise SweepSpecError(
            f'{where}: servo takes choices = ["<key>", ...]: the catalogue servos to try'
        )
    if len(raw) > MAX_CHOICES:
        raise SweepSpecError(f"{where}: {len(raw)} choices; at most {MAX_CHOICES}")
    keys = tuple(check_servo(key, where) for key in raw)
    twice = sorted({k for k in keys if keys.count(k) > 1})
    if twice:
        raise SweepSpecError(f"{where}: choice(s) {', '.join(twice)} given twice")
    return keys


def fixed_part(value: Any, source: str) -> tuple[tuple[str, Any], ...]:
    """The [part] table: (("servo", key), ("kp", value)) as given."""
    if not isinstance(value, dict):
        raise SweepSpecError(f"{source}: [part] must be a table (servo, kp)")
    unknown = sorted(set(value) - set(PART_NAMES))
    if unknown:
        raise SweepSpecError(
            f"{source}: [part] unknown key(s) {', '.join(unknown)}; known: servo, kp"
        )
    out: list[tuple[str, Any]] = []
    if "servo" in value:
        out.append(("servo", check_servo(value["servo"], f"{source}: [part]")))
    if "kp" in value:
        out.append(("kp", check_kp(value["kp"], f"{source}: [part]")))
    return tuple(out)


@dataclasses.dataclass(frozen=True)
class PartSetup:
    """The servo part of a point: picklable (a key and numbers), to travel to a worker."""

    servo: str
    kp: float | None = None
    """None: the record's firmware kp."""
    dead_band_deg: float | None = None
    """None: the record's backlash."""


def leg_parts(robot: Any, part: PartSetup) -> Any:
    """ServoParts of `part` on every leg joint of `robot` (the joints the uniform preset
    compensates); StudioError (ServoPartsError) for settings the part cannot take."""
    from app.core.servo.catalogue import load_catalogue
    from app.core.servo.parts import parts_from_mapping
    from app.core.servo.presets import uniform_preset

    legs = [
        name
        for name, on in zip(robot.joint_names, uniform_preset(robot).enabled, strict=True)
        if on
    ]
    table: dict[str, Any] = {"servo": part.servo}
    if part.kp is not None:
        table["kp"] = part.kp
    if part.dead_band_deg is not None:
        table["dead_band_deg"] = part.dead_band_deg
    return parts_from_mapping(table, legs, load_catalogue(), f"sweep part {part.servo}")
