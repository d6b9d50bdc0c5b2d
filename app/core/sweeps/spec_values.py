"""The checks of a sweep file's values, one by one: typed values and numbers, one
[[parameter]] entry into a SweepParameter (its gait, robot, servo or part range), and the fixed
[servo] table. spec.py puts them together into a SweepSpec.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

from app.core.collocation.settings import GaitSettings, GaitSettingsError
from app.core.errors import refuse_unknown_keys
from app.core.sweeps.part_parameters import PART_NAMES, check_kp, choices_of
from app.core.sweeps.robot_variants import SweepSpecError, robot_parameter
from app.core.sweeps.servo_metrics import SERVO_PARAMETERS

MAX_POINTS = 20_000
"""Most points one sweep may have: 20 000 gait solves are hours on a laptop."""
DEFAULT_LEVELS = 3
KINDS = ("gait", "robot", "servo", "part")
PARAMETER_KEYS = ("name", "kind", "min", "max", "levels", "choices")
STRUCTURAL = ("baseline",)
"""Settings a sweep cannot vary (not a number)."""
KIND_WORDS = {int: "whole number", str: "text", bool: "true or false", dict: "table", list: "list"}


@dataclasses.dataclass(frozen=True)
class SweepParameter:
    """One swept number: its kind, its name and its closed range [minimum, maximum]."""

    kind: str
    name: str
    minimum: float
    maximum: float
    levels: int = DEFAULT_LEVELS
    """Grid values of this parameter (grid sampling only)."""
    choices: tuple[str, ...] = ()
    """A categorical parameter's values (the servo keys of kind "part"); its value at a
    point is the index of its choice."""

    def shown(self, value: float) -> str:
        """A point's value as the user reads it: a choice's key, else the number."""
        if self.choices:
            return self.choices[min(max(round(value), 0), len(self.choices) - 1)]
        return f"{value:.4g}"

    @property
    def is_integer(self) -> bool:
        if self.kind == "part":
            return True
        if self.kind == "servo":
            return SERVO_PARAMETERS[self.name].is_switch
        return self.kind == "gait" and isinstance(getattr(GaitSettings, self.name), int)


def typed(value: Any, kind: type, what: str) -> Any:
    """`value` if it is a `kind` (a bool is no number), else SweepSpecError naming `what`."""
    if not isinstance(value, kind) or (kind is not bool and isinstance(value, bool)):
        raise SweepSpecError(f"{what} = {value!r} is not a {KIND_WORDS[kind]}")
    return value


def integer(value: Any, what: str) -> int:
    """`value` as a whole number (SweepSpecError: another type)."""
    return int(typed(value, int, what))


def finite_number(value: Any, what: str) -> float:
    """`value` as a finite float (SweepSpecError: not a number, NaN or infinite)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise SweepSpecError(f"{what} = {value!r} is not a number")
    if not math.isfinite(value):
        raise SweepSpecError(f"{what} = {value}: give a finite number")
    return float(value)


def sweep_parameter(
    entry: Any, where: str, robot: str, base: GaitSettings, files: tuple[Any, ...]
) -> SweepParameter:
    """One [[parameter]] table checked: known keys, a kind, a range inside what the planner
    (`base` settings), the robot builder, the servo model or the part accepts."""
    entry = typed(entry, dict, where)
    refuse_unknown_keys(entry, PARAMETER_KEYS, SweepSpecError, where)
    if "name" not in entry:
        raise SweepSpecError(f"{where}: missing 'name'")
    name = typed(entry["name"], str, f"{where}: name")
    kind = typed(entry.get("kind", "gait"), str, f"{where}: kind")
    if kind == "part" and name == "servo":
        if {"min", "max", "levels"} & set(entry):
            raise SweepSpecError(f"{where}: servo is categorical: give choices, not min/max/levels")
        keys = choices_of(entry, f"{where} (servo)", files)
        return SweepParameter(kind, name, 0.0, float(len(keys) - 1), len(keys), keys)
    if "choices" in entry:
        raise SweepSpecError(f"{where}: choices are for the part parameter servo only")
    for key in ("min", "max"):
        if key not in entry:
            raise SweepSpecError(f"{where}: missing {key!r}")
    lo = finite_number(entry["min"], f"{where} ({name}): min")
    hi = finite_number(entry["max"], f"{where} ({name}): max")
    levels = integer(entry.get("levels", DEFAULT_LEVELS), f"{where} ({name}): levels")
    if not 1 <= levels <= MAX_POINTS:
        raise SweepSpecError(f"{where} ({name}): levels = {levels}; give 1 to {MAX_POINTS}")
    if lo > hi:
        raise SweepSpecError(f"{where} ({name}): min = {lo:g} > max = {hi:g}")
    if kind == "gait":
        _check_gait_range(name, lo, hi, base, where)
    elif kind == "robot":
        p = robot_parameter(robot, name)
        if lo < p.minimum or hi > p.maximum:
            raise SweepSpecError(
                f"{where}: {name} range [{lo:g}, {hi:g}] leaves what the {robot} builder "
                f"accepts, [{p.minimum:g}, {p.maximum:g}]"
            )
    elif kind == "servo":
        _check_servo_range(name, lo, hi, where)
    elif kind == "part":
        if name not in PART_NAMES:
            raise SweepSpecError(
                f"{where}: unknown part parameter {name!r}; known: {', '.join(PART_NAMES)}"
            )
        check_kp(lo, where), check_kp(hi, where)
    else:
        raise SweepSpecError(f"{where}: kind = {kind!r}; give one of {', '.join(KINDS)}")
    return SweepParameter(kind, name, lo, hi, levels)


def _check_gait_range(name: str, lo: float, hi: float, base: GaitSettings, where: str) -> None:
    fields = {f.name for f in dataclasses.fields(GaitSettings)}
    if name not in fields or name in STRUCTURAL:
        numeric = [f for f in fields if f not in STRUCTURAL]
        raise SweepSpecError(
            f"{where}: unknown gait parameter {name!r}; known: {', '.join(sorted(numeric))}"
        )
    for value in (lo, hi):
        typed: float | int = round(value) if isinstance(getattr(base, name), int) else value
        try:
            dataclasses.replace(base, **{name: typed}).validate()  # type: ignore[arg-type]
        except GaitSettingsError as error:
            raise SweepSpecError(
                f"{where}: {name} range [{lo:g}, {hi:g}] leaves what the planner accepts: {error}"
            ) from None


def _check_servo_range(name: str, lo: float, hi: float, where: str) -> None:
    if name not in SERVO_PARAMETERS:
        raise SweepSpecError(
            f"{where}: unknown servo parameter {name!r}; known: {', '.join(SERVO_PARAMETERS)}"
        )
    p = SERVO_PARAMETERS[name]
    if lo < p.minimum or hi > p.maximum:
        raise SweepSpecError(
            f"{where}: {name} range [{lo:g}, {hi:g}] leaves [{p.minimum:g}, {p.maximum:g}] "
            f"({p.hint})"
        )


def servo_table(value: Any, source: str) -> tuple[tuple[str, float], ...]:
    """The fixed [servo] table as sorted (name, value) pairs, each inside its range."""
    table = typed(value, dict, f"{source}: [servo]")
    out = []
    for name, raw in sorted(table.items()):
        where = f"{source}: [servo] {name}"
        number = float(raw) if isinstance(raw, bool) else finite_number(raw, where)
        _check_servo_range(name, number, number, f"{source}: [servo]")
        out.append((name, number))
    return tuple(out)
