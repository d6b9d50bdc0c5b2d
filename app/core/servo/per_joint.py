"""What the per-joint servo records (`CompensationParams`, `ServoModel`) share: one checked,
read-only value per joint, and the same values laid out on another list of joints (their base
record, `PerJointRecord`)."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import ClassVar, Self

import numpy as np

from app.core.errors import StudioError, refuse_unknown_joints


@dataclasses.dataclass(frozen=True, eq=False)
class PerJointRecord:
    """Values per joint of `joint_names`: each field named in `COLUMNS` holds one per joint,
    shape (n,), checked by the subclass (`per_joint`, `check_range`)."""

    joint_names: tuple[str, ...]
    COLUMNS: ClassVar[tuple[str, ...]] = ()
    """The per-joint array fields, in the order the subclass declares them."""
    ERROR: ClassVar[type[StudioError]] = StudioError
    """What the subclass refuses values with."""

    def for_joints(self, joint_names: Sequence[str]) -> Self:
        """The same values laid out on `joint_names` (a robot's joints, in its order), the
        other fields kept. A joint not named here gets zero (False); a joint named here that
        the robot lacks is `ERROR`, so a typo never silently drops a value."""
        joint_names = tuple(joint_names)
        if joint_names == self.joint_names:
            return self
        columns = [getattr(self, name) for name in self.COLUMNS]
        laid = laid_out(self.joint_names, joint_names, columns, self.ERROR)
        return dataclasses.replace(
            self, joint_names=joint_names, **dict(zip(self.COLUMNS, laid, strict=True))
        )


def per_joint(label: str, value: object, n: int, error: type[StudioError]) -> np.ndarray:
    """`value` as a read-only array of shape (n,), or `error` saying what is wrong with it."""
    try:
        array: np.ndarray = np.array(value, dtype=float).reshape(-1)
    except (TypeError, ValueError) as failure:
        raise error(f"{label} must be numbers: {failure}") from None
    if array.shape != (n,):
        raise error(f"{label} has {array.size} value(s) for {n} joint(s); give one per joint")
    array.flags.writeable = False
    return array


def laid_out(
    names: Sequence[str],
    joint_names: Sequence[str],
    arrays: Sequence[np.ndarray],
    error: type[StudioError],
) -> list[np.ndarray]:
    """Per-joint `arrays` on `names` laid out on `joint_names` (a robot's joints, its order):
    zero (False) on a joint not in `names`; `error` for a name the robot does not have."""
    refuse_unknown_joints(names, joint_names, error)
    index = {name: i for i, name in enumerate(names)}
    rows = [index.get(name) for name in joint_names]
    out = []
    for array in arrays:
        laid = np.zeros(len(joint_names), dtype=array.dtype)
        for j, i in enumerate(rows):
            if i is not None:
                laid[j] = array[i]
        out.append(laid)
    return out


def check_range(
    symbol: str,
    array: np.ndarray,
    names: Sequence[str],
    bounds: tuple[float, float],
    unit: str,
    error: type[StudioError],
    why: str = "",
) -> None:
    """`error` naming the first joint whose value is not a number within `bounds` (inclusive;
    `unit` follows each number, `why` the line)."""
    lower, upper = bounds
    for value, name in zip(array, names, strict=True):
        if not (math.isfinite(value) and lower <= value <= upper):
            span = (
                f"a number within ±{upper:g}"
                if lower == -upper
                else f"between {lower:g} and {upper:g}{unit}"
            )
            raise error(f"{symbol} of {name} is {float(value):g}{unit}; it must be {span}{why}")
