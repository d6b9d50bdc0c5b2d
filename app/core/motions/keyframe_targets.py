"""The IK targets of a keyframed motion's samples (app.core.motions.keyframes), a segment's
samples at once: the time law, the interpolated placements of the moving feet and the pelvis
(their rotations by one Rodrigues formula over the segment), the CoM's ground projection, and
moving-foot targets put back on the floor.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from app.core.motions.interpolant import Blend, min_jerk_many, trapezoid_many
from app.core.motions.keyframe_guards import CONTACT_BAND_M
from app.core.motions.keyframe_records import Keyframe, _foot
from app.core.posing.ik import IkTargets
from app.core.robot.model import RobotModel


def segment_targets(
    robot: RobotModel,
    before: Keyframe,
    after: Keyframe,
    start: dict[str, np.ndarray],
    tau: np.ndarray,
) -> list[IkTargets]:
    """IK targets at the phases τ (m,) of the segment from `before` to `after` (keyframes'
    module docstring); `start`: where the feet, pelvis and CoM were when the segment started
    (keyframe_guards._where). Stance feet are held where they stood then; moving-foot targets
    that dip less than CONTACT_BAND_M below the floor are put on it (on_floor)."""
    s = trapezoid_many(tau) if after.profile == "trapezoid" else min_jerk_many(tau)
    stance = after.stance
    feet: dict[str, np.ndarray | list[np.ndarray]] = {}
    for foot in robot.feet:
        side = foot.side
        if stance in (side, "both"):
            feet[side] = [start[side]] * len(tau)  # held where it stood when the segment started
            continue
        blend = Blend.of(_foot(before, side), _foot(after, side))
        if after.swing_height_m > 0.0:
            phase = np.pi * s
            T = blend.at_many(0.5 * (1.0 - np.cos(phase)))
            T[:, 2, 3] += after.swing_height_m * np.sin(phase)
        else:
            T = blend.at_many(s)
        _raise_to_floor(T, foot.sole_corners_m)
        feet[side] = T
    pelvis: np.ndarray | list[None] = [None] * len(tau)
    if after.T_world_pelvis is not None:
        T0 = before.T_world_pelvis if before.T_world_pelvis is not None else start["pelvis"]
        pelvis = Blend.of(np.asarray(T0), np.asarray(after.T_world_pelvis)).at_many(s)
    com: np.ndarray | list[None] = [None] * len(tau)
    if after.com_xy is not None:
        c0 = np.asarray(before.com_xy if before.com_xy is not None else start["com"], float)
        com = c0 + s[:, None] * (np.asarray(after.com_xy, dtype=float) - c0)
    return [
        IkTargets(left, right, T_pelvis, com_xy, stance)
        for left, right, T_pelvis, com_xy in zip(
            feet["left"], feet["right"], pelvis, com, strict=True
        )
    ]


def _raise_to_floor(Ts: np.ndarray, sole_corners_m: np.ndarray) -> None:
    """In place: placements (m, 4, 4) whose sole dips less than CONTACT_BAND_M below the floor
    raised to 1 nm above it (see on_floor)."""
    lowest = (Ts[:, 2, :3] @ sole_corners_m.T).min(axis=1) + Ts[:, 2, 3]
    dipping = (lowest > -CONTACT_BAND_M) & (lowest < 0.0)
    Ts[dipping, 2, 3] += 1e-9 - lowest[dipping]


def on_floor(robot: RobotModel, targets: IkTargets) -> IkTargets:
    """Moving-foot targets whose sole dips less than CONTACT_BAND_M below the floor (the
    residue of an IK solve the keyframe was captured from) put on the floor."""
    raised: dict[str, np.ndarray] = {}
    for foot in robot.feet:
        field = "T_world_left" if foot.side == "left" else "T_world_right"
        T = getattr(targets, field)
        if T is None or targets.stance in (foot.side, "both"):
            continue
        lowest = float((T[:3, :3] @ foot.sole_corners_m.T)[2].min() + T[2, 3])
        if -CONTACT_BAND_M < lowest < 0.0:
            raised[field] = np.array(T, dtype=float)
            raised[field][2, 3] += 1e-9 - lowest  # 1 nm above: clear of rounding
    return dataclasses.replace(targets, **raised) if raised else targets  # type: ignore[arg-type]
