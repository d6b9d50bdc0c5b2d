"""The whole-body IK's verdict on a solved pose: how far each target was missed, whether it
counts as reached, the CoM's margin, the joints near a limit, and the warning and shortfall
text the studio shows (what holds the pose back: app.core.posing.shortfall).

IkVerdictMixin is one part of app.core.posing.ik.WholeBodyIK (state set up by its __init__).
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from app.core.posing.ik_records import (
    COM_TARGET_WEIGHT,
    REACHED_M,
    REACHED_RAD,
    TORSO_WEIGHT,
    IkResult,
    IkTargets,
    _Ended,
)
from app.core.posing.shortfall import NOTHING_PUSHED, Bounded, Goal, Situation, blockers
from app.core.posing.support_polygon import OFF_POLYGON, SupportPolygonMixin

NEAR_LIMIT_RAD = np.deg2rad(3.0)
TORSO_TURN_RAD = np.deg2rad(5.0)
"""A torso held at an orientation that ends further than this from it is a fold the user did
not ask for: the result is not `reached`."""
OUT_OF_REACH = " target out of reach: closest pose is "
"""The words of the warning a missed target gives (its distance follows)."""
HELD_BACK_BY = "held back by "
"""The words a shortfall's line on what holds the pose back starts with."""


def explains(line: str) -> bool:
    """Whether a shortfall's line says what holds the pose back (not how far a target is)."""
    return line.startswith(HELD_BACK_BY) or line == NOTHING_PUSHED


class IkVerdictMixin(SupportPolygonMixin):
    """The verdict's part of WholeBodyIK."""

    com_margin_m: float
    _pelvis_frame: str
    _pelvis_id: int
    _torso_goal: np.ndarray | None
    _ended: _Ended | None
    _bounded_names: tuple[str, ...]
    _bounded_q: np.ndarray
    _bounded_lower: np.ndarray
    _bounded_upper: np.ndarray
    _bounded_info: Bounded
    _bounded_list: list[tuple[str, int, float, float]]

    def _result(
        self,
        q: np.ndarray,
        iterations: int,
        targets: IkTargets,
        wanted: dict[str, np.ndarray],
        warnings: list[str],
        polygon: np.ndarray | None,
        explain: bool = True,
    ) -> IkResult:
        """How close q came to the wanted placements (and CoM), its CoM margin (in `polygon`,
        when the stance feet were held where the solve found them; else the polygon at q), the
        joints near a limit: from one forward kinematics pass. `explain`: what holds back a
        pose short of its targets is looked for (the shortfall's "held back by" lines)."""
        robot, data = self.robot, self._data
        if self._placed_q is not q:  # the solve failed: not placed by _anchor
            pin.framesForwardKinematics(robot.model, data, q)
        oMf = data.oMf
        feet = {side: oMf[frame].homogeneous for side, frame in self._foot_ids.items()}
        placed = dict(feet)
        position_error, orientation_error = {}, {}
        shortfall = []
        for label, T_target in wanted.items():
            if label == "pelvis":
                T = placed["pelvis"] = oMf[self._pelvis_id].homogeneous
            else:
                T = feet[label]
            delta = T[:3, 3] - T_target[:3, 3]
            distance = position_error[label] = math.sqrt(float(delta.dot(delta)))
            turn = pin.log3(T_target[:3, :3].T.dot(T[:3, :3]))
            angle = orientation_error[label] = math.sqrt(float(turn.dot(turn)))
            if distance >= REACHED_M or angle >= REACHED_RAD:
                shortfall.append(
                    f"{label if label == 'pelvis' else label + ' foot'} {distance * 1000:.1f} "
                    f"mm, {np.rad2deg(angle):.1f}° from its target"
                )
        reached = not shortfall
        if not reached:
            worst = max(wanted, key=lambda k: position_error[k])
            warnings.append(
                f"{worst}{OUT_OF_REACH}{position_error[worst] * 1000:.1f} mm, "
                f"{np.rad2deg(orientation_error[worst]):.1f}° away"
            )
        if self._torso_goal is not None:
            R = oMf[self._pelvis_id].rotation
            turn = pin.log3(self._torso_goal.T.dot(R))
            orientation_error["torso"] = math.sqrt(float(turn.dot(turn)))
            if orientation_error["torso"] >= TORSO_TURN_RAD:
                reached = False
                shortfall.append(
                    f"torso turned {np.rad2deg(orientation_error['torso']):.0f}° from where it was"
                )
        if polygon is None:
            polygon = self._polygon_here(targets.stance, feet)
        com_xy = np.array(pin.centerOfMass(robot.model, data, False))[:2]  # data placed at q
        if targets.com_xy is not None:
            miss = com_xy - np.asarray(targets.com_xy)[:2]
            position_error["com"] = math.sqrt(float(miss @ miss))
            if position_error["com"] >= REACHED_M:
                reached = False
                warnings.append(
                    f"CoM target out of reach: {position_error['com'] * 1000:.1f} mm away"
                )
                shortfall.append(f"CoM {position_error['com'] * 1000:.1f} mm from its target")
        margin = self._margin_of(com_xy, polygon)
        if explain and not reached:
            shortfall += self._blockers(q, targets, wanted)
        self._ended = _Ended(
            q.tobytes(),
            targets.stance,
            placed,
            polygon,
            margin >= 0.0,
            reached,
        )
        return IkResult(
            q,
            reached,
            iterations,
            position_error,
            orientation_error,
            margin,
            self._near_limits(q),
            tuple(warnings),
            tuple(shortfall),
            placed,
            explain or reached,
        )

    def _near_limits(self, q: np.ndarray) -> tuple[str, ...]:
        """The joints within NEAR_LIMIT_RAD of a limit at q."""
        angles = q.tolist()  # a few dozen joints: Python floats beat numpy's per-call cost
        return tuple(
            name
            for name, i, lower, upper in self._bounded_list
            if angles[i] - lower < NEAR_LIMIT_RAD or upper - angles[i] < NEAR_LIMIT_RAD
        )

    def _blockers(
        self, q: np.ndarray, targets: IkTargets, wanted: dict[str, np.ndarray]
    ) -> list[str]:
        """What holds q back from the soft targets (app.core.posing.shortfall); self._data's
        frames are placed at q."""
        robot = self.robot
        ids = robot.link_frame_ids
        stance_sides = ("left", "right") if targets.stance == "both" else (targets.stance,)
        goals = [
            Goal(ids[self._pelvis_frame] if k == "pelvis" else self._foot_ids[k], T)
            for k, T in wanted.items()
            if k not in stance_sides
        ]
        edges = None
        if self._polygon_on and self._polygon_wanted is not OFF_POLYGON:
            normals, offsets = self._edges(self._polygon_wanted)
            edges = (normals, offsets - self.com_margin_m)
        torso = None
        if self._torso_goal is not None:
            torso = (ids[self._pelvis_frame], self._torso_goal, TORSO_WEIGHT)
        situation = Situation(
            tuple(goals),
            tuple(self._foot_ids[side] for side in stance_sides),
            self._bounded_info,
            None if targets.com_xy is None else np.asarray(targets.com_xy, dtype=float)[:2],
            COM_TARGET_WEIGHT,
            edges,
            torso,
        )
        return [
            reason if reason == NOTHING_PUSHED else HELD_BACK_BY + reason
            for reason in blockers(robot.model, self._data, q, situation)
        ]
