"""BAM's identified servo models (robots/servos/bam/params: Rhoban's Better Actuator Models,
Apache-2.0): the motor constants and the m1 / m6 friction fits of each, read and checked."""

from __future__ import annotations

import dataclasses
import json
from typing import Any

from app.core.servo.motor_law import FrictionM1, FrictionM6, MotorConstants
from app.core.servo.record_numbers import ServoCatalogueError, number_field
from robots.catalogue import ROBOTS_DIR

__all__ = ["BAM_PARAMS_DIR", "IdentifiedModel", "identified_model", "identified_names"]

BAM_PARAMS_DIR = ROBOTS_DIR / "servos" / "bam" / "params"
M6_FIELDS = tuple(f.name for f in dataclasses.fields(FrictionM6))


@dataclasses.dataclass(frozen=True)
class IdentifiedModel:
    """A servo model identified on a bench (BAM): motor, m1 fit and, where identified, m6."""

    name: str
    motor: MotorConstants | None
    """None where the fit gives no winding resistance (eRob80-100)."""
    m1: FrictionM1
    m6: FrictionM6 | None
    m6_motor: MotorConstants | None
    """kt, R, armature of the m6 fit (each fit identifies its own)."""


def _bam_file(name: str, model: str) -> dict[str, Any] | None:
    path = BAM_PARAMS_DIR / name / f"{model}.json"
    if not path.is_file():
        return None
    data = json.loads(path.read_text())
    if not isinstance(data, dict):
        raise ServoCatalogueError(f"{path}: not a BAM parameter file")
    return data


def identified_model(name: str) -> IdentifiedModel:
    """The BAM fits of `name` (a folder of robots/servos/bam/params), checked."""
    available = sorted(p.name for p in BAM_PARAMS_DIR.iterdir() if p.is_dir())
    if name not in available:
        raise ServoCatalogueError(
            f"identified model {name!r} is not one of BAM's: {', '.join(available)}"
        )
    m1 = _bam_file(name, "m1")
    if m1 is None:
        raise ServoCatalogueError(f"BAM model {name} has no m1 fit")
    where = f"BAM {name} m1"
    motor = None
    if "R" in m1:
        motor = MotorConstants(
            number_field(m1, "kt", where, positive=True),
            number_field(m1, "R", where, positive=True),
            number_field(m1, "armature", where, positive=False),
        )
    friction = FrictionM1(
        number_field(m1, "friction_base", where, positive=False),
        number_field(m1, "friction_viscous", where, positive=False),
    )
    m6 = _bam_file(name, "m6")
    m6_friction, m6_motor = None, None
    if m6 is not None:
        where = f"BAM {name} m6"
        m6_friction = FrictionM6(
            **{n: number_field(m6, n, where, positive=False) for n in M6_FIELDS}
        )
        if "R" in m6:
            m6_motor = MotorConstants(
                number_field(m6, "kt", where, positive=True),
                number_field(m6, "R", where, positive=True),
                number_field(m6, "armature", where, positive=False),
            )
    return IdentifiedModel(name, motor, friction, m6_friction, m6_motor)


def identified_names() -> tuple[str, ...]:
    """Every BAM model shipped (robots/servos/bam/params)."""
    return tuple(sorted(p.name for p in BAM_PARAMS_DIR.iterdir() if p.is_dir()))
