"""`first_samples`: the start of a motion, to keep a test short."""

from __future__ import annotations

import dataclasses

from app.core.motions.trajectory import Trajectory


def first_samples(trajectory: Trajectory, n: int) -> Trajectory:
    """The first `n` samples of `trajectory` (every per-sample field cut alike)."""
    rows = slice(0, n)
    return dataclasses.replace(
        trajectory,
        **{name: getattr(trajectory, name)[rows] for name in ("t", "q", "v", "a", "contacts")},
    )
