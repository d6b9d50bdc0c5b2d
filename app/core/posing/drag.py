"""Posing by dragging: which feet hold, what a drag means, snapping feet to the ground.

Pure state and computation (no GUI): the studio feeds drag targets in and draws what comes
out. Dragging a foot makes the other foot the stance foot; dragging the pelvis keeps the
current stance.

A drag is a gesture: its events (one per gizmo move) continue it while each starts from the
pose the previous one returned; any other pose (a button, a slider, another handle) starts a
new one. Through a gesture:
- the posture task pulls towards the pose the gesture started from, so that the joints the
  targets leave free stay where the user left them, whatever path the handle took;
- a foot drag holds the torso at its orientation at the start (IkTargets.R_world_torso): the
  legs lift the foot, the body does not fold over to reach it;
- a foot drag that starts with the moving leg straight (standing: a singular leg, whose knee
  does not lift the foot to first order) starts from the knees bent instead
  (app.core.posing.ready_pose.crouch: the pelvis READY_CROUCH of the leg lower).

Each event's IK stops at the first step that meets the goals to within what is visible
(WholeBodyIK.solve's stop_when_met: the foot within 0.1 mm of its target, the torso hold within
0.1 mrad): one QP per event on a smooth drag instead of two or three to see the steps vanish.
A target out of reach is iterated as before, to its closest pose. What holds such a pose back
(the "held back by" lines: Jacobians, a projection, a small NNLS; ~0.1 ms on Roban S14, half
the IK's own Python on an event out of reach) is worked out on the gesture's first event short
of the target, on every EXPLAIN_EVERY-th one after, and whenever the caller asks (the studio:
when the handle is released); the events between list the misses alone (IkResult.explained
is False) and the studio keeps the last lines: rewritten at the pointer's 20 Hz they are not
read, and the poses are the same either way.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pinocchio as pin

from app.core.errors import StudioError
from app.core.posing.ik import IkResult, IkTargets, Stance, WholeBodyIK
from app.core.posing.ready_pose import MOTION_POSTURE_WEIGHT, crouch, leg_is_straight
from app.core.robot.model import RobotModel

EXPLAIN_EVERY = 4
"""A drag out of reach says what holds it back on every 4th event (5 Hz at viser's 20 Hz
pointer events) besides its first miss and the release (module docstring)."""
MAX_DRAG_DISTANCE_M = 100.0
"""A drag target further than this from the origin is refused (a crafted client, not a hand)."""


class DragTargetError(StudioError, ValueError):
    """A drag target that is not a placement: NaN, infinite, a zero quaternion, far away."""


def drag_target(position_m: np.ndarray, quat_wxyz: np.ndarray) -> np.ndarray:
    """The 4x4 placement of a dragged handle from a position [m] and a (w, x, y, z) quaternion
    (normalised here); DragTargetError when either is not finite, the quaternion's norm is
    below 1e-9 or a coordinate of the position is beyond ±MAX_DRAG_DISTANCE_M."""
    position = np.asarray(position_m, dtype=float).reshape(-1)
    quat = np.asarray(quat_wxyz, dtype=float).reshape(-1)
    if position.shape != (3,) or quat.shape != (4,):
        raise DragTargetError("a drag target needs 3 position and 4 quaternion values")
    if not (np.all(np.isfinite(position)) and np.all(np.isfinite(quat))):
        raise DragTargetError("the drag target is not finite; drag the handle again")
    largest = float(np.max(np.abs(quat)))
    quat = quat / largest if largest > 0.0 else quat  # no overflow in the norm of 1e308s
    norm = float(np.linalg.norm(quat)) * largest
    if norm < 1e-9:
        raise DragTargetError("the drag target's orientation is a zero quaternion")
    if float(np.max(np.abs(position))) > MAX_DRAG_DISTANCE_M:
        raise DragTargetError(
            f"the drag target is {np.max(np.abs(position)):.3g} m away; at most "
            f"{MAX_DRAG_DISTANCE_M:g} m"
        )
    w, x, y, z = quat / np.linalg.norm(quat)
    T = np.eye(4)
    T[:3, :3] = pin.Quaternion(w, x, y, z).toRotationMatrix()
    T[:3, 3] = position
    return T


@dataclasses.dataclass(frozen=True)
class Balance:
    """What the balance overlay shows for a configuration."""

    polygon_xy: np.ndarray
    """Support polygon corners [m], shape (N, 2), counter-clockwise."""
    com_world: np.ndarray
    com_margin_m: float
    """Distance of the CoM's ground projection inside the polygon [m] (negative: outside)."""
    joints_near_limit: tuple[str, ...]
    joint_positions_near_limit: list[np.ndarray]
    contact_frames: list[np.ndarray]
    """4x4 placements of the sole corners of the stance feet."""


@dataclasses.dataclass(frozen=True)
class _Gesture:
    """A drag in progress (module docstring)."""

    which: str
    q_start: np.ndarray
    """The pose it started from (the knees bent first if the moving leg was straight): the
    posture task's target."""
    R_world_torso: np.ndarray | None
    """The torso's orientation at q_start, held through a foot drag (None for the pelvis)."""
    q_last: bytes
    """The configuration its last event returned (exact bytes): the next event continues the
    gesture only from there."""
    since_explained: int | None = None
    """Events short of the target since the last one explained (None: the next one is
    explained, at the gesture's start and after an event that reached its target)."""


class Posing:
    """Drag-to-pose state of one robot."""

    def __init__(self, robot: RobotModel, com_in_support: bool = True) -> None:
        self.robot = robot
        self.ik = WholeBodyIK(robot, com_in_support=com_in_support)
        self.stance: Stance = "both"
        self._data = robot.model.createData()
        self._gesture: _Gesture | None = None
        self._crouch_ik: WholeBodyIK | None = None
        """The IK that bends straight legs at a gesture's start, made on first need: its
        solve holds both feet (hard equalities that a 5-DOF leg cannot take, which would
        turn the drag IK's stance soft for good) and counts as no drag solve."""

    @property
    def com_in_support(self) -> bool:
        return self.ik.com_in_support

    @com_in_support.setter
    def com_in_support(self, on: bool) -> None:
        self.ik.com_in_support = on

    def drag(
        self,
        q: np.ndarray,
        which: str,
        T_world_target: np.ndarray,
        *,
        explain: bool | None = None,
    ) -> IkResult:
        """Solve for a dragged handle ("left", "right" or "pelvis") reaching T_world_target.

        explain: True, a result short of its target says what holds it back (the handle was
        released); None, on the gesture's cadence (module docstring: its first miss and every
        EXPLAIN_EVERY-th event); False, never."""
        T = np.asarray(T_world_target, dtype=float)
        if T.shape != (4, 4) or not math.isfinite(float(T.sum())):  # any NaN or inf: not finite
            raise DragTargetError("the drag target is not a finite placement; drag again")
        if which not in ("left", "right", "pelvis"):
            raise DragTargetError(f"no handle named {which!r}; handles: left, right, pelvis")
        gesture = self._gesture
        if gesture is None or gesture.which != which or gesture.q_last != q.tobytes():
            gesture = self._start(q, which)
            q = gesture.q_start
        if which in ("left", "right"):
            other = "right" if which == "left" else "left"
            if self.stance in (which, "both"):
                self.stance = other  # type: ignore[assignment]
            targets = IkTargets(
                **{f"T_world_{which}": T},
                stance=self.stance,
                posture_q=gesture.q_start,
                R_world_torso=gesture.R_world_torso,
            )
        else:
            targets = IkTargets(T_world_pelvis=T, stance=self.stance, posture_q=gesture.q_start)
        since = gesture.since_explained
        if explain is None:
            explain = since is None or since >= EXPLAIN_EVERY - 1
        result = self.ik.solve(q, targets, stop_when_met=True, explain=explain)
        self._gesture = _Gesture(
            gesture.which,
            gesture.q_start,
            gesture.R_world_torso,
            result.q.tobytes(),
            None if result.reached else 0 if result.explained else (since or 0) + 1,
        )
        return result

    def _start(self, q: np.ndarray, which: str) -> _Gesture:
        """A new gesture from q: from the knees bent when a foot is dragged on a straight leg."""
        robot = self.robot
        start = np.array(q, dtype=float)
        if which == "pelvis" or not robot.floating_base:
            return _Gesture(which, start, None, b"")
        if leg_is_straight(robot, start, which):
            if self._crouch_ik is None:
                self._crouch_ik = WholeBodyIK(robot, posture_weight=MOTION_POSTURE_WEIGHT)
            start = crouch(robot, start, self._crouch_ik, stance="both").q
        pin.framesForwardKinematics(robot.model, self._data, start)
        R = self._data.oMf[robot.link_frame_ids[robot.tree.root]].rotation.copy()
        return _Gesture(which, start, R, b"")

    def snap_feet_to_ground(self, q: np.ndarray) -> IkResult:
        """Put both soles flat on z = 0, keeping each foot's x, y and heading; both feet stance after."""
        placements = self.robot.link_placements(q, self._data)
        targets = {}
        for foot in self.robot.feet:
            T = placements[foot.link]
            heading = np.arctan2(T[1, 0], T[0, 0])
            flat = np.eye(4)
            flat[:3, :3] = pin.rpy.rpyToMatrix(0.0, 0.0, heading)
            # Sole corners in the foot frame, rotated flat: the lowest must land on z = 0.
            sole_z = (flat[:3, :3] @ foot.sole_corners_m.T)[2].min()
            flat[:3, 3] = [T[0, 3], T[1, 3], -sole_z]
            targets[foot.side] = flat
        self.stance = "both"
        return self.ik.solve(
            q,
            IkTargets(
                T_world_left=targets["left"],
                T_world_right=targets["right"],
                stance="both",
                posture_q=q,
            ),
        )

    def swap_stance(self) -> Stance:
        self.stance = {"left": "right", "right": "left", "both": "both"}[self.stance]  # type: ignore[assignment]
        return self.stance

    def balance(self, q: np.ndarray) -> Balance:
        """The balance overlay at q, from one forward-kinematics pass (placements of only the
        stance feet and of the joints near a limit; the CoM once)."""
        robot, data = self.robot, self._data
        polygon = self.ik.support_polygon(q, self.stance)
        pin.framesForwardKinematics(robot.model, data, q)
        oMf, ids = data.oMf, robot.link_frame_ids
        com = np.array(pin.centerOfMass(robot.model, data, q))
        angles = robot.joint_angles(q)
        near, positions = [], []
        for joint, angle in zip(robot.joints, angles, strict=True):
            if joint.kind != "continuous" and min(
                angle - joint.lower, joint.upper - angle
            ) < np.deg2rad(3.0):
                near.append(joint.name)
                positions.append(oMf[ids[robot.tree.joints[joint.name].child]].translation.copy())
        sides = ("left", "right") if self.stance == "both" else (self.stance,)
        contacts = []
        for foot in robot.feet:
            if foot.side in sides:
                T = oMf[ids[foot.link]].homogeneous
                centre = foot.sole_corners_m.mean(axis=0)
                frame = T.copy()
                frame[:3, 3] = T[:3, :3] @ centre + T[:3, 3]
                contacts.append(frame)
        return Balance(
            polygon, com, self.ik.margin_at(com[:2], polygon), tuple(near), positions, contacts
        )
