"""Parameters of the built-in motions: declared with defaults and units, checked when given.

Values come from Python (numbers) or from the command line (text, `--param NAME=VALUE`); a
parameter whose default is None ("scaled to the robot") also takes "auto".
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping

from app.core.motions.poses import MotionError

MAX_COUNT = 100
"""Largest count (squats, swings, steps) a motion takes: each adds keyframes and seconds."""
MAX_MAGNITUDE = 10.0
"""Largest |value| of a length [m] or speed [m/s] parameter: no biped moves 10 m in a step."""


@dataclasses.dataclass(frozen=True)
class Param:
    name: str
    default: float | int | str | None
    """None: scaled to the robot (see `help`)."""
    unit: str
    """"m", "m/s", "" (a count, a factor or a choice)."""
    help: str
    kind: type = float
    choices: tuple[str, ...] = ()
    minimum: float | None = 0.0
    """Smallest accepted value (None: any)."""
    maximum: float | None = None
    """Largest accepted value (None: any; counts always have one, see MAX_COUNT)."""

    @property
    def upper_bound(self) -> float | None:
        """`maximum`, or MAX_COUNT for a count without one."""
        if self.maximum is None and self.kind is int:
            return MAX_COUNT
        return self.maximum

    def to_json(self) -> dict[str, object]:
        return {
            "name": self.name,
            "default": self.default,
            "unit": self.unit,
            "help": self.help,
            "type": self.kind.__name__,
            **({"choices": list(self.choices)} if self.choices else {}),
            **(
                {"minimum": self.minimum}
                if self.minimum is not None and self.kind is not str
                else {}
            ),
            **(
                {"maximum": self.upper_bound}
                if self.upper_bound is not None and self.kind is not str
                else {}
            ),
        }


def parse_params(
    motion: str, params: tuple[Param, ...], given: Mapping[str, object]
) -> dict[str, object]:
    """Every parameter of a motion: its default, or the given value checked and converted."""
    declared = {p.name: p for p in params}
    unknown = [key for key in given if key not in declared]
    if unknown:
        raise MotionError(
            f"motion {motion!r} has no parameter {unknown[0]!r}; its parameters are: "
            + ", ".join(declared)
        )
    values: dict[str, object] = {p.name: p.default for p in params}
    for key, raw in given.items():
        values[key] = _value(declared[key], raw, motion)
    return values


def _value(param: Param, raw: object, motion: str) -> object:
    where = f"motion {motion!r}, parameter {param.name!r}"
    if param.default is None and raw in (None, "auto"):
        return None
    if param.kind is str:
        if raw not in param.choices:
            raise MotionError(f"{where}: {raw!r}; use one of {', '.join(param.choices)}")
        return raw
    try:
        number = float(raw)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise MotionError(f"{where}: {raw!r} is not a number") from None
    if not math.isfinite(number):
        raise MotionError(f"{where}: {raw!r} is not a finite number")
    if param.minimum is not None and number < param.minimum:
        raise MotionError(f"{where}: {raw!r} is below its minimum {param.minimum:g}")
    upper = param.upper_bound
    if upper is None and param.unit in ("m", "m/s"):
        upper = MAX_MAGNITUDE
        if abs(number) > upper:
            raise MotionError(f"{where}: {raw!r} is beyond ±{upper:g} {param.unit}")
    if upper is not None and number > upper:
        raise MotionError(f"{where}: {raw!r} is above its maximum {upper:g}")
    if param.kind is int:
        if number != round(number):
            raise MotionError(f"{where}: {raw!r} is not a whole number")
        return round(number)
    return number
