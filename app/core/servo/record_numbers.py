"""The servo records' error and number check, shared by the catalogue's reader (`catalogue`)
and BAM's identified models (`bam_models`)."""

from __future__ import annotations

import math
from typing import Any

from app.core.errors import StudioError

__all__ = ["ServoCatalogueError", "number_field"]


class ServoCatalogueError(StudioError):
    """A catalogue record or a user's servo file that cannot be used."""


def number_field(data: dict[str, Any], name: str, where: str, *, positive: bool) -> float:
    """data[name] as a finite float (≥ 0, or > 0 when `positive`); one line naming it else."""
    if name not in data:
        raise ServoCatalogueError(f"{where}: {name} is missing")
    value = data[name]
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ServoCatalogueError(f"{where}: {name} is {value!r}; give a number")
    value = float(value)
    if not math.isfinite(value):
        raise ServoCatalogueError(f"{where}: {name} is {value}; give a finite number")
    if value < 0.0 or (positive and value == 0.0):
        bound = "> 0" if positive else "≥ 0"
        raise ServoCatalogueError(f"{where}: {name} is {value:g}; it must be {bound}")
    return value
