"""Key poses for the built-in motions, each solved so that the keyframes are consistent.

- Every built-in motion starts from the ready pose (app.core.posing.ready_pose).
- KeyframeSequence appends keyframes one solved pose at a time, starting from the ready pose.
- A pose with the CoM over a point: the pelvis target (upright) is moved horizontally by the
  remaining CoM error until the CoM is there (a fixed-point iteration: the CoM follows the
  pelvis at a ratio below 1 with the feet planted). When the CoM stops approaching its target
  (e.g. a leg without ankle roll cannot carry the pelvis over one foot), the closest pose is
  kept and the shortfall reported.
"""

from __future__ import annotations

import dataclasses
from typing import Literal

import numpy as np

from app.core.motions.keyframes import Keyframe, capture_keyframe
from app.core.posing.ik import IkTargets, Stance, WholeBodyIK
from app.core.posing.ready_pose import MOTION_POSTURE_WEIGHT, PoseError, ready_pose
from app.core.robot.model import RobotModel

Side = Literal["left", "right"]

COM_TOLERANCE_M = 1e-4
POSE_ITERATIONS = 200
REACH_M = 1e-3
"""A key pose whose moving foot ends further than this from its target is noted."""
STANCE_SLIP_M = 5e-4
"""A solved key pose whose standing feet moved more than this is rejected."""


class MotionError(PoseError):
    """A built-in motion that cannot be made for this robot or with these parameters."""


@dataclasses.dataclass(frozen=True)
class PoseContext:
    """What the motions need to know about a robot, computed once."""

    robot: RobotModel
    ik: WholeBodyIK
    leg_length_m: float
    """Hip height above the soles at the standing pose [m]."""
    q_ready: np.ndarray
    ready_warnings: tuple[str, ...]

    def placements(self, q: np.ndarray) -> dict[str, np.ndarray]:
        return self.robot.link_placements(q, self.robot.model.createData())

    def foot(self, q: np.ndarray, side: str) -> np.ndarray:
        return self.placements(q)[self.robot.foot(side).link]

    def sole_centre(self, q: np.ndarray, side: str) -> np.ndarray:
        """Centre of a sole's corners in the world [m], shape (3,)."""
        T = self.foot(q, side)
        corners = self.robot.foot(side).sole_corners_m
        return T[:3, :3] @ corners.mean(axis=0) + T[:3, 3]

    def over_sole(self, q: np.ndarray, side: str, xy: np.ndarray, margin_m: float) -> np.ndarray:
        """The point nearest to xy [m] over a sole's rectangle shrunk by margin_m (world xy)."""
        T = self.foot(q, side)
        corners = self.robot.foot(side).sole_corners_m[:, :2]
        local = T[:2, :2].T @ (np.asarray(xy, dtype=float) - T[:2, 3])
        low, high = corners.min(axis=0) + margin_m, corners.max(axis=0) - margin_m
        middle = 0.5 * (low + high)
        local = np.clip(local, np.minimum(low, middle), np.maximum(high, middle))
        return T[:2, :2] @ local + T[:2, 3]

    def com(self, q: np.ndarray) -> np.ndarray:
        return self.robot.com(q, self.robot.model.createData())


def pose_context(robot: RobotModel) -> PoseContext:
    """Leg length and ready pose of a floating-base robot."""
    ik = WholeBodyIK(robot, posture_weight=MOTION_POSTURE_WEIGHT)
    ready = ready_pose(robot, ik)
    return PoseContext(robot, ik, ready.leg_length_m, ready.q, ready.warnings)


def pose_with_com(
    ctx: PoseContext,
    q_start: np.ndarray,
    stance: Stance,
    *,
    com_xy: np.ndarray | None = None,
    pelvis_z: float | None = None,
    left: np.ndarray | None = None,
    right: np.ndarray | None = None,
    com_in_support: bool = True,
) -> tuple[np.ndarray, tuple[str, ...]]:
    """Solve a pose: feet at their targets (stance feet held), pelvis upright (at pelvis_z if
    given), CoM's ground projection at com_xy if given. Returns (q, warnings)."""
    T_pelvis = ctx.placements(q_start)[ctx.robot.tree.root].copy()
    T_pelvis[:3, :3] = np.eye(3)
    if pelvis_z is not None:
        T_pelvis[2, 3] = pelvis_z
    if com_xy is not None:
        T_pelvis[:2, 3] += np.asarray(com_xy) - ctx.com(q_start)[:2]
    best: tuple[float, np.ndarray, tuple[str, ...]] | None = None
    for _ in range(12):
        targets = IkTargets(left, right, T_pelvis.copy(), None, stance)
        result = ctx.ik.solve(
            q_start, targets, com_in_support=com_in_support, max_iterations=POSE_ITERATIONS
        )
        if com_xy is None:
            return result.q, result.warnings
        miss = np.asarray(com_xy) - ctx.com(result.q)[:2]
        error = float(np.linalg.norm(miss))
        if best is not None and error > 0.8 * best[0]:
            break  # the CoM no longer follows the pelvis
        best = (error, result.q, result.warnings)
        if error < COM_TOLERANCE_M:
            break
        T_pelvis[:2, 3] += miss
    assert best is not None
    error, q, warnings = best
    if error >= 1e-3:
        warnings = (*warnings, f"CoM target out of reach: {error * 1000:.1f} mm away")
    return q, warnings


@dataclasses.dataclass(frozen=True)
class Plan:
    """A motion before interpolation: its keyframes and how it was adapted to the robot."""

    keyframes: tuple[Keyframe, ...]
    notes: tuple[str, ...] = ()
    held_joints: tuple[str, ...] = ()
    """Joints the interpolation holds at their first keyframe's angles (the arms, waist and
    head of a built-in motion)."""
    com_in_support: bool = True
    """False when the motion asks for a CoM outside its support (the paper's shift wider than
    the sole): the IK then lets the CoM go where it is asked instead of holding it inside."""


LEGS = ("Left leg", "Right leg")


def non_leg_joints(robot: RobotModel) -> tuple[str, ...]:
    """The actuated joints outside the legs (arms, waist, head...)."""
    return tuple(
        joint.name
        for joint in robot.joints
        if joint.limb not in LEGS and joint.kind != "continuous"
    )


class KeyframeSequence:
    """Keyframes appended one pose at a time, each solved from the previous one, starting
    from the ready pose; durations are divided by `speed`."""

    def __init__(self, robot: RobotModel, speed: float = 1.0) -> None:
        if not speed > 0.0:
            raise MotionError(f"speed {speed}; it must be positive")
        self.ctx = pose_context(robot)
        self.robot, self.speed, self.q = robot, speed, self.ctx.q_ready
        self.keyframes = [capture_keyframe(robot, self.q, "both", "ready", 0.0)]
        self.notes: list[str] = []
        self.held = non_leg_joints(robot)
        ready = robot.joint_angles(self.q)
        index = {name: i for i, name in enumerate(robot.joint_names)}
        self.ctx.ik.hold_joints({name: float(ready[index[name]]) for name in self.held})
        self.com_in_support = True
        """Set to False by a motion that asks for its CoM outside the support."""

    def add(
        self,
        name: str,
        duration_s: float,
        stance: Stance,
        com_xy: np.ndarray | None = None,
        *,
        pelvis_z: float | None = None,
        feet: dict[Side, np.ndarray] | None = None,
        **options,
    ) -> None:
        """Solve the pose (pose_with_com) and append it; `options` go to the Keyframe. The
        keyframe keeps the wanted com_xy, so the interpolation reports it if out of reach."""
        feet = feet or {}
        q, _ = pose_with_com(
            self.ctx,
            self.q,
            stance,
            com_xy=com_xy,
            pelvis_z=pelvis_z,
            left=feet.get("left"),
            right=feet.get("right"),
            com_in_support=self.com_in_support,
        )
        held = ("left", "right") if stance == "both" else (stance,)
        slid = max(
            np.linalg.norm(self.ctx.foot(q, side)[:3, 3] - self.ctx.foot(self.q, side)[:3, 3])
            for side in held
        )
        if slid > STANCE_SLIP_M:  # an IK compromise moved a standing foot: do not use it
            self.notes.append(
                f"{name!r}: no pose found with the standing feet in place; the previous pose "
                "is kept as this keyframe"
            )
        else:
            self.q = q
        for side, T_wanted in feet.items():
            short = np.linalg.norm(self.ctx.foot(self.q, side)[:3, 3] - T_wanted[:3, 3])
            if side not in held and short > REACH_M:
                self.notes.append(
                    f"{name!r}: the {side} foot stops {short * 1000:.1f} mm short of its target"
                )
        kf = capture_keyframe(self.robot, self.q, stance, name, duration_s / self.speed, **options)
        if com_xy is not None:
            kf = dataclasses.replace(kf, com_xy=np.asarray(com_xy, dtype=float))
        self.keyframes.append(kf)

    def foot(self, side: str, dx: float = 0.0, dy: float = 0.0, dz: float = 0.0) -> np.ndarray:
        """Where a foot is now, moved by (dx, dy, dz) [m] in the world."""
        T = self.ctx.foot(self.q, side).copy()
        T[:3, 3] += (dx, dy, dz)
        return T

    def plan(self) -> Plan:
        return Plan(tuple(self.keyframes), tuple(self.notes), self.held, self.com_in_support)
