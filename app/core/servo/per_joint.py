"""What the per-joint servo records (`CompensationParams`, `ServoModel`) share: one checked,
read-only value per joint, and the same values laid out on another list of joints."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from app.core.errors import StudioError, refuse_unknown_joints


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
