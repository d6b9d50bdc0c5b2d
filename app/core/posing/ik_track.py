"""The whole-body IK following a motion: one QP step per sample where that converges.

A keyframed motion asks the IK, every 10 ms, for targets a fraction of a millimetre from the
previous sample's. `WholeBodyIK.solve` iterates to convergence (until a step is shorter than
1e-6: about three QPs per sample, each judged by a line search on the goal cost). `track`
starts instead from a prediction of the answer — the previous solution moved on by the
previous sample's motion, q_k-1 ⊕ (q_k-1 ⊖ q_k-2), within the change of the motion's speed
over one sample (~1e-4 rad) of it — and takes one Gauss–Newton step (one QP) from there: what
the step leaves is of the order of its length squared, and the next sample's step corrects it
in turn. A step longer than TRACK_STEP (a keyframe where the motion turns sharply, a target
the legs cannot follow), or one whose pose misses a target (REACHED_M, REACHED_RAD: the
targets compete, and `solve`'s line search settles the compromise), is not trusted alone: the
sample is solved by `solve` from the previous solution, as before; so are the samples after
one that missed a target, and those whose situation `solve` handles in ways one step does not
(the stance changed, the CoM outside the support polygon, a target below the floor, a torso
hold or a posture of its own, a failed QP). A target further than solve's clamped step
(MAX_STEP_M, MAX_STEP_RAD) needs no test of its own: clamping shapes only the way there, and
a single step that ends within REACHED_M of every target ends where solve's iterations do.

IkTrackMixin is one part of app.core.posing.ik.WholeBodyIK (state set up by its __init__).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pinocchio as pin

from app.core.posing.ik_records import REACHED_M, REACHED_RAD, IkResult, IkTargets, _Ended
from app.core.posing.ik_verdict import IkVerdictMixin
from app.core.robot.loops import close_loops

TRACK_STEP = 1e-3
"""[rad or m, the norm of the configuration step] A predicted start whose one QP step is
shorter than this is taken as solved: the step's own error is of the order of its square
(Gauss–Newton from within 1e-3: ~1e-6 and below, where solve's iterations stop)."""


class IkTrackMixin(IkVerdictMixin):
    """The motion-following part of WholeBodyIK."""

    com_in_support: bool
    _pelvis_id: int
    solve: Callable[..., IkResult]
    _set_posture: Callable[[np.ndarray], None]
    _set_tasks: Callable[
        [IkTargets, dict[str, np.ndarray]],
        tuple[dict[str, np.ndarray], tuple[str, ...], list[str], bool],
    ]
    _anchor: Callable[[np.ndarray, dict[str, np.ndarray]], np.ndarray]

    def track(
        self,
        q_from: np.ndarray,
        targets: IkTargets,
        guess: np.ndarray | None = None,
        *,
        com_in_support: bool | None = None,
        max_iterations: int = 60,
        explain: bool = True,
    ) -> IkResult:
        """The next sample of a motion: q_from is this IK's last answer, the targets moved a
        little since. One QP step from `guess` (a prediction of the answer; q_from when None)
        when that step is short enough and its pose reaches the targets, else solve(q_from,
        targets) (module docstring). The same record as solve's (`explain` as there);
        `iterations` is 1 for one step."""
        use_polygon = self.com_in_support if com_in_support is None else com_in_support
        result = self._one_step(q_from, targets, guess, use_polygon)
        if result is not None:
            return result
        return self.solve(
            q_from,
            targets,
            com_in_support=com_in_support,
            max_iterations=max_iterations,
            explain=explain,
        )

    def _one_step(
        self,
        q_from: np.ndarray,
        targets: IkTargets,
        guess: np.ndarray | None,
        use_polygon: bool,
    ) -> IkResult | None:
        """The single-step answer of track, or None when `solve` must answer."""
        ended = self._ended
        if ended is None or not _trackable(ended, q_from, targets, use_polygon):
            return None
        robot = self.robot
        self._placed_q = None
        self._set_posture(robot.q_neutral)
        wanted, stance_sides, warnings, held_in_place = self._set_tasks(targets, ended.placements)
        if warnings:
            return None  # a target below the floor: solve aims above it
        wrapper = self._wrapper
        wrapper.state.q = q_from if guess is None else guess
        wrapper.update_kinematics()
        self._set_polygon(use_polygon, ended.polygon if use_polygon else None)
        self._set_com_pull(None)
        self._push_polygon()
        try:
            dq = self._solver.solve(True)  # placo applies the step: wrapper.state.q = guess ⊕ dq
        except RuntimeError:
            return None  # solve knows what to do (a rank-deficient stance: held by weight)
        if not float(dq.dot(dq)) <= TRACK_STEP * TRACK_STEP:  # also NaN
            return None
        q = wrapper.state.q.copy()
        if robot.tree.loops:
            q = close_loops(robot, q, self._data).q
        q = self._anchor(q, {side: wanted[side] for side in stance_sides})
        return self._verdict(q, targets, wanted, ended.polygon if held_in_place else None)

    def _verdict(
        self,
        q: np.ndarray,
        targets: IkTargets,
        wanted: dict[str, np.ndarray],
        polygon: np.ndarray | None,
    ) -> IkResult | None:
        """The result of a single step at q (self._data's frames placed there by _anchor) when
        it reaches every target (what _result says of such a pose, measured the same way,
        without its text), else None."""
        oMf = self._data.oMf
        placed = {side: oMf[frame].homogeneous for side, frame in self._foot_ids.items()}
        if "pelvis" in wanted:
            placed["pelvis"] = oMf[self._pelvis_id].homogeneous
        position_error, orientation_error = {}, {}
        for label, T_target in wanted.items():
            T = placed[label]
            delta = T[:3, 3] - T_target[:3, 3]
            distance = math.sqrt(float(delta.dot(delta)))
            turn = pin.log3(T_target[:3, :3].T.dot(T[:3, :3]))
            angle = math.sqrt(float(turn.dot(turn)))
            if distance >= REACHED_M or angle >= REACHED_RAD:
                return None
            position_error[label], orientation_error[label] = distance, angle
        com_xy = np.array(pin.centerOfMass(self.robot.model, self._data, False)[:2])
        if targets.com_xy is not None:
            miss = com_xy - np.asarray(targets.com_xy)[:2]
            position_error["com"] = math.sqrt(float(miss.dot(miss)))
            if position_error["com"] >= REACHED_M:
                return None
        if polygon is None:
            polygon = self._polygon_here(targets.stance, placed)
        margin = self._margin_of(com_xy, polygon)
        self._ended = _Ended(q.tobytes(), targets.stance, placed, polygon, margin >= 0.0)
        return IkResult(
            q,
            True,
            1,
            position_error,
            orientation_error,
            margin,
            self._near_limits(q),
            (),
            (),
            placed,
        )


def _trackable(ended: _Ended, q_from: np.ndarray, targets: IkTargets, use_polygon: bool) -> bool:
    """Whether q_from is where the IK's last solve ended, with this stance, every target reached
    (where the last sample missed one, the targets compete and the next sample's most likely
    do too: solve answers without a step tried first) and (when the polygon is used) the CoM
    inside it, and the targets ask for nothing only solve does."""
    return (
        ended.stance == targets.stance
        and ended.reached
        and (ended.com_inside or not use_polygon)
        and targets.posture_q is None
        and targets.R_world_torso is None
        and ended.q == q_from.tobytes()
    )
