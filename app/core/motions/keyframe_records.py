"""A keyframe of a keyframed motion (where the feet, pelvis and CoM should be, which feet stand,
how it is reached), captured from a configuration, and the checks that keyframes can be
interpolated (app.core.motions.keyframes).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Literal

import numpy as np

from app.core.errors import StudioError
from app.core.posing.ik import Stance
from app.core.robot.model import RobotModel

Profile = Literal["min_jerk", "trapezoid"]
STANCE_TOLERANCE_M = 1e-3
"""A stance foot may differ by this much between the two keyframes of its segment."""


class KeyframeError(StudioError):
    """Keyframes that cannot be interpolated (too few, bad durations, NaN, moving stance)."""


@dataclasses.dataclass(frozen=True, eq=False)
class Keyframe:
    """A task-space pose of the robot, and how to reach it from the previous keyframe."""

    name: str
    duration_s: float
    """Time to reach this keyframe from the previous one [s] (unused for the first)."""
    T_world_left: np.ndarray
    """Placement of the left foot link, 4x4 [m]."""
    T_world_right: np.ndarray
    T_world_pelvis: np.ndarray | None = None
    """Placement of the pelvis (root link), 4x4 [m]; None leaves it free."""
    com_xy: np.ndarray | None = None
    """Ground projection of the CoM [m], shape (2,); None leaves it free."""
    stance: Stance = "both"
    """Feet held fixed while this keyframe is reached; the others follow their targets."""
    swing_height_m: float = 0.0
    """Apex of the moving foot's semi-elliptical path above its chord [m]; 0: straight line."""
    profile: Profile = "min_jerk"
    """Time law of the segment reaching this keyframe."""
    q: np.ndarray | None = None
    """The configuration the keyframe was captured from, if any: seeds the IK at the start."""


def capture_keyframe(
    robot: RobotModel, q: np.ndarray, stance: Stance, name: str, duration_s: float, **options
) -> Keyframe:
    """A keyframe holding the feet, pelvis and CoM where they are at configuration q."""
    data = robot.model.createData()
    placements = robot.link_placements(q, data)
    left, right = (placements[foot.link] for foot in robot.feet)
    return Keyframe(
        name=name,
        duration_s=duration_s,
        T_world_left=left,
        T_world_right=right,
        T_world_pelvis=placements[robot.tree.root],
        com_xy=robot.com(q, data)[:2],
        stance=stance,
        q=np.array(q, dtype=float),
        **options,
    )


def validate(keyframes: Sequence[Keyframe]) -> None:
    """Raise KeyframeError naming the first keyframe that cannot be interpolated."""
    if len(keyframes) < 2:
        raise KeyframeError(f"a motion needs at least 2 keyframes, got {len(keyframes)}")
    for i, kf in enumerate(keyframes):
        label = f"keyframe {i} ({kf.name!r})"
        if i > 0 and not (math.isfinite(kf.duration_s) and kf.duration_s > 0.0):
            raise KeyframeError(
                f"{label}: duration {kf.duration_s} s; it must be a positive number of seconds"
            )
        for field in ("T_world_left", "T_world_right", "T_world_pelvis", "com_xy"):
            value = getattr(kf, field)
            shape = (2,) if field == "com_xy" else (4, 4)
            if value is None and field in ("T_world_pelvis", "com_xy"):
                continue
            array = np.asarray(value, dtype=float)
            if array.shape != shape or not np.all(np.isfinite(array)):
                raise KeyframeError(f"{label}: {field} must be {shape} finite numbers")
            if shape == (4, 4) and not np.allclose(
                array[:3, :3].T @ array[:3, :3], np.eye(3), atol=1e-6
            ):
                raise KeyframeError(f"{label}: {field} is not a rigid transform")
        if kf.stance not in ("left", "right", "both"):
            raise KeyframeError(f"{label}: stance {kf.stance!r}; use 'left', 'right' or 'both'")
        if not (math.isfinite(kf.swing_height_m) and kf.swing_height_m >= 0.0):
            raise KeyframeError(f"{label}: swing height {kf.swing_height_m} m must be ≥ 0")
        if i == 0:
            continue
        for side in ("left", "right") if kf.stance == "both" else (kf.stance,):
            moved = np.linalg.norm(_foot(kf, side)[:3, 3] - _foot(keyframes[i - 1], side)[:3, 3])
            if moved > STANCE_TOLERANCE_M:
                raise KeyframeError(
                    f"{label}: the {side} foot stands (stance {kf.stance!r}) but is "
                    f"{moved * 1000:.1f} mm away from where the previous keyframe puts it"
                )


def _foot(kf: Keyframe, side: str) -> np.ndarray:
    return np.asarray(kf.T_world_left if side == "left" else kf.T_world_right, dtype=float)
