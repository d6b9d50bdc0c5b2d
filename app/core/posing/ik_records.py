"""The whole-body IK's records and the numbers its modules share.

What a solve is asked (IkTargets) and what it answers (IkResult), where the last solve ended
(_Ended: the next solve starting there reuses it), the reach thresholds and the weights of the
tasks that more than one of the IK's modules reads (app.core.posing.ik builds the tasks;
ik_steps weighs the goals; ik_verdict says what holds a pose back).
"""

from __future__ import annotations

import dataclasses
from typing import Literal

import numpy as np

Stance = Literal["left", "right", "both"]
REACHED_M = 1e-3
"""A target closer than this (and REACHED_RAD) counts as reached."""
REACHED_RAD = np.deg2rad(0.5)
COM_TARGET_WEIGHT = 10.0
TORSO_WEIGHT = 1.0
"""[per rad², beside the moving foot's 1 per m²] of the torso hold: tilting the torso by a
degree costs what missing the foot by 17 mm does, so the legs do the work and a lean appears
only for a target the legs cannot reach (then reported: TORSO_TURN_RAD)."""


@dataclasses.dataclass(frozen=True)
class IkTargets:
    """Where the feet and pelvis should be. None leaves a frame free (pelvis) or where it is (feet)."""

    T_world_left: np.ndarray | None = None
    T_world_right: np.ndarray | None = None
    T_world_pelvis: np.ndarray | None = None
    com_xy: np.ndarray | None = None
    """Where the CoM's ground projection should be [m] (soft, heavier than the feet)."""
    stance: Stance = "both"
    """Feet held (overwhelming weight) at their target, or where they are when they have none;
    the other foot follows its target (soft)."""
    posture_q: np.ndarray | None = None
    """Configuration whose joint angles the light posture task pulls towards (the redundancy:
    what the targets leave free); None for the standing pose. Drag posing passes the pose
    before the drag, so that moving a foot moves its leg and leaves the rest near where it
    was."""
    R_world_torso: np.ndarray | None = None
    """Orientation (3x3) the torso (the root link) is held at (soft, TORSO_WEIGHT); None leaves
    it free. Not used with a pelvis target (whose orientation is the pelvis's)."""


@dataclasses.dataclass(frozen=True)
class IkResult:
    q: np.ndarray
    """The solved configuration (the start configuration if the solve failed)."""
    reached: bool
    """Every soft target within REACHED_M and REACHED_RAD."""
    iterations: int
    position_error_m: dict[str, float]
    """Per target ("left", "right", "pelvis", "com") distance to it [m]."""
    orientation_error_rad: dict[str, float]
    com_margin_m: float
    """Distance of the CoM's ground projection inside the support polygon [m] (negative: outside)."""
    joints_near_limit: tuple[str, ...]
    warnings: tuple[str, ...]
    shortfall: tuple[str, ...] = ()
    """Why this is only the closest reachable pose (empty when reached): each target missed
    and by how much, the torso turned from where it was held, then what holds the pose back
    (a joint at a limit the targets push against, the CoM polygon, the torso hold)."""
    placements: dict[str, np.ndarray] = dataclasses.field(default_factory=dict)
    """Where the feet ("left", "right") and a pelvis with a target ("pelvis") are at q, 4x4
    [m] (from the forward kinematics the errors were measured with; not to be modified)."""
    explained: bool = True
    """Whether `shortfall` went through what holds the pose back (always when reached: there is
    nothing to explain; a solve with explain=False, or a drag event between explanations
    (app.core.posing.drag.EXPLAIN_EVERY), lists only the misses)."""


@dataclasses.dataclass(frozen=True)
class _Ended:
    """Where a solve ended: its configuration (exact bytes), stance, the placements there of
    the feet ("left", "right") and of a pelvis that had a target ("pelvis"), the support polygon
    its result was measured in and whether the CoM is inside it."""

    q: bytes
    stance: Stance
    placements: dict[str, np.ndarray]
    polygon: np.ndarray
    com_inside: bool
    reached: bool = True
    """Whether its result reached every target (a motion's next sample is then tracked)."""
