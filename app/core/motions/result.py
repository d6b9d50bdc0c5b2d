"""What interpolating a motion gives: the trajectory, and what the IK could not do along it."""

from __future__ import annotations

import dataclasses
import re

from app.core.motions.continuity import JUMP_PREFIX
from app.core.motions.trajectory import Trajectory


@dataclasses.dataclass(frozen=True)
class SampleWarning:
    index: int
    """Sample index in the trajectory."""
    time_s: float
    keyframe: str
    """Name of the keyframe being reached."""
    message: str


@dataclasses.dataclass(frozen=True)
class MotionResult:
    """A sampled motion and what the IK could not do along it."""

    trajectory: Trajectory
    warnings: tuple[SampleWarning, ...]
    """One entry per IK warning per sample, in time order."""
    notes: tuple[str, ...] = ()
    """Motion-level remarks (e.g. how an amplitude was adapted to the robot)."""

    @property
    def jump_samples(self) -> tuple[int, ...]:
        """Samples where the IK would have moved a joint faster than its limit (clipped, see
        app.core.motions.continuity): their targets are missed, their torques are not peaks."""
        return tuple(sorted({w.index for w in self.warnings if w.message.startswith(JUMP_PREFIX)}))

    def summary(self) -> tuple[str, ...]:
        """Notes, then warnings grouped per keyframe and kind, one line each."""
        groups: dict[tuple[str, str], list[SampleWarning]] = {}
        for warning in self.warnings:
            kind = re.sub(r"-?\d+(\.\d+)?", "#", warning.message)
            groups.setdefault((warning.keyframe, kind), []).append(warning)
        lines = list(self.notes)
        for (keyframe, _), items in groups.items():
            worst = max(items, key=lambda w: _magnitude(w.message))
            lines.append(
                f"{keyframe!r}, t = {items[0].time_s:.2f}–{items[-1].time_s:.2f} s "
                f"({len(items)} samples), worst: {worst.message}"
            )
        return tuple(lines)


def _magnitude(message: str) -> float:
    """The first number in a message (0 if none), to pick the worst of similar warnings."""
    found = re.search(r"\d+(\.\d+)?", message)
    return float(found.group()) if found else 0.0
