"""The whole-body IK's iterations: QP steps with a line search on the goal cost, far targets
approached a step at a time, and the rule that says the steps have vanished (or, for a drag,
that the goals are met) and the solve stops.

IkStepsMixin is one part of app.core.posing.ik.WholeBodyIK (state set up by its __init__).
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import placo

from app.core.posing.ik_records import REACHED_M, TORSO_WEIGHT
from app.core.posing.support_polygon import SupportPolygonMixin

ROTATION_WEIGHT = 0.01
"""[m²/rad²] in the goal cost used to accept steps: 0.1 rad counts like 1 cm."""
MAX_STEP_M = 0.03
MAX_STEP_RAD = 0.3
MAX_STEP_M2, MAX_STEP_RAD2 = MAX_STEP_M**2, MAX_STEP_RAD**2
"""A soft target further than this is approached through intermediate targets (one per QP
step): a far, unreachable target otherwise asks for huge steps at a stretched, near-singular
leg, and the iterations jump between configurations instead of settling."""
GOAL_MET_COST = 1e-8
"""[m²] A goal cost below this (the soft goals within 0.1 mm, 10× inside REACHED_M) needs no
line search for a small step (< SMALL_STEP): the steps from there are the corrections of a
converging solve."""
CRAWL_COST = (0.3 * REACHED_M) ** 2
CRAWL_GAIN = 0.01
"""[m², -] stop_when_met also stops where the goals are within a third of REACHED_M and a small
step (< SMALL_STEP) lowered their cost by less than this fraction: the steps crawl along an
active constraint (the CoM on the polygon's edge, a joint at its limit) for micrometres."""
CONTRACTING = 0.5
SMALL_STEP = 1e-3
"""[rad or m] Steps are judged converging from their ratio only once both are this small: the
first steps of a solve are large, nonlinear moves whose ratio says nothing of the tail."""
HELD_MERIT_WEIGHT = 100.0
"""While the torso is held, the held feet's drift from their targets weighs this much in the
goal cost that accepts steps: near the edge of what the legs reach upright, the QP asks for
long steps whose second-order drift of a held foot (the QP holds it to first order only) can
reach centimetres; the rigid correction of the base (_anchor) would then swing the whole
robot by that much."""


_Here = tuple[np.ndarray | None, np.ndarray | None, bool]
"""Where a soft goal's frame is, its turn to the goal (log3), whether the goal is further
than a step; the first two only when it is."""
_NEAR = (None, None, False)

GoalPart = tuple[str, np.ndarray, placo.PositionTask, placo.OrientationTask]
"""A soft goal in the goal cost: its frame, its 4x4 target, and the position and orientation
parts of the frame task aimed at it."""


class IkStepsMixin(SupportPolygonMixin):
    """The iterations' part of WholeBodyIK."""

    _pelvis_frame: str
    _torso: placo.OrientationTask | None
    _soft_goals: list[tuple[placo.FrameTask, str, np.ndarray]]
    _aimed: list[np.ndarray]
    _goal_parts: list[GoalPart]
    _held_parts: list[tuple[placo.PositionTask, placo.OrientationTask]]
    _goals_here: list[_Here]

    def _iterate(
        self,
        start: np.ndarray,
        polygon: np.ndarray | None,
        max_iterations: int,
        step_tolerance: float,
        stop_when_met: bool = False,
    ) -> tuple[np.ndarray, int]:
        """QP steps from start until they vanish; the CoM is guarded when a polygon is given.

        Each step is the longest of dq, dq/2, … dq/16 that lowers the goal cost (any step
        while the CoM is being pulled into the polygon, when there is no soft goal or, for a
        small step, when the goals are met to GOAL_MET_COST); when
        none does, the iterations stop where they are: iterating further would only wander.
        The goals do not change during the iterations, so the cost an accepted step was
        judged by is the cost the next step starts from.

        The steps vanish when one is shorter than step_tolerance, or when, contracting by a
        ratio ρ = |dq_k| / |dq_k-1| ≤ CONTRACTING from one small step to the next, all that
        remains of them (at most |dq_k|·ρ / (1 − ρ)) is: near the solution the iterations
        converge linearly (the light posture and damping tasks pull against the goals), and the
        last two or three QPs would each move the pose by less than a micrometre. A vanishing
        step is taken as it is, without a line search (at that size the goal cost's change is
        rounding). Once settled — the steps contracting so, or small (< SMALL_STEP) after the
        goals were met to GOAL_MET_COST — the steps are taken without a line search and without
        computing the goal cost again (the iterations are converging: there is nothing for it
        to guard), the targets aimed where they were. With stop_when_met, a step the line
        search accepts with the goal cost below GOAL_MET_COST, or crawling below CRAWL_COST,
        ends the iterations (solve)."""
        wrapper, model, solver = self._wrapper, self.robot.model, self._solver
        q = start.copy()
        wrapper.state.q = q
        wrapper.update_kinematics()
        self._set_polygon(False)
        self._set_com_pull(None)
        goals, aimed = self._soft_goals, self._aimed
        cost: float | None = None
        previous_step = math.inf
        settled = False
        iterations = 0
        for iterations in range(1, max_iterations + 1):  # noqa: B007 - returned
            if polygon is not None and not self._polygon_on:
                self._guard_com(polygon)
            if not settled:
                if cost is None:
                    cost = self._goal_cost()
                self._aim(goals, aimed)
            self._push_polygon()
            dq = solver.solve(True)  # placo applies the full step: wrapper.state.q = q ⊕ dq
            squared = float(dq.dot(dq))
            if not math.isfinite(squared) and not np.all(np.isfinite(dq)):
                raise FloatingPointError("non-finite step")
            step = math.sqrt(squared)
            ratio = step / previous_step if previous_step < SMALL_STEP else 1.0
            previous_step = step
            converging = ratio <= CONTRACTING
            if step < step_tolerance or (
                converging and step * ratio < step_tolerance * (1.0 - ratio)
            ):
                q = wrapper.state.q.copy()  # a view of placo's state otherwise
                break
            met = step < SMALL_STEP and cost is not None and cost < GOAL_MET_COST
            settled = converging or (step < SMALL_STEP and settled) or met
            pulling = polygon is not None and not self._polygon_on
            wrapper.update_kinematics()
            if pulling or not goals or settled or met:
                q = wrapper.state.q.copy()  # a view of placo's state otherwise
                cost = None
                continue
            if cost is None:  # after steps taken without a line search: the cost at q
                wrapper.state.q = q
                wrapper.update_kinematics()
                cost = self._goal_cost()
                wrapper.state.q = pin.integrate(model, q, dq)
                wrapper.update_kinematics()
            for gain in (1.0, 0.5, 0.25, 0.125, 0.0625):
                if gain != 1.0:  # the full step is in the wrapper already
                    wrapper.state.q = pin.integrate(model, q, gain * dq)
                    wrapper.update_kinematics()
                after = self._goal_cost()
                if after < cost * (1.0 - 1e-9):
                    q, gain_kept, cost = wrapper.state.q.copy(), 1.0 - after / cost, after
                    break
            else:  # no step along dq lowers the goal cost: the closest pose is reached
                wrapper.state.q = q
                wrapper.update_kinematics()
                break
            if stop_when_met and (
                cost < GOAL_MET_COST
                or (cost < CRAWL_COST and step < SMALL_STEP and gain_kept < CRAWL_GAIN)
            ):
                break  # the goals are met: what further steps change is not visible
        return q, iterations

    def _aim(self, goals: list, aimed: list[np.ndarray]) -> None:
        """Each soft goal's task aimed at its goal, or MAX_STEP towards it when it is further
        (from where the goal cost was last computed)."""
        for i, ((task, _, goal), (current, turn, far)) in enumerate(
            zip(goals, self._goals_here, strict=True)
        ):
            aim = goal
            if far:
                assert current is not None  # measured where the goal is far
                aim = _clamped_towards(current, goal, turn)
            if aim is not aimed[i]:
                task.T_world_frame = aim
                aimed[i] = aim

    def _goal_cost(self) -> float:
        """Weighted distance of the soft goals: Σ |Δp|² [m²] + ROTATION_WEIGHT·|Δθ|² [rad²];
        while a torso is held, its turn from the hold (TORSO_WEIGHT·|Δθ|², as in the QP: a
        step that straightens the torso while the foot lags is a step forward) and the held
        feet's drift (HELD_MERIT_WEIGHT).

        Each distance is the error placo's own task measures at the wrapper's kinematics
        (PositionTask: target − current; OrientationTask: |log3| of the turn to the target,
        the same angle as log3(R_currentᵀ·R_goal)) wherever that task holds the goal itself:
        one C++ call per task instead of a dozen small numpy operations. A goal whose task
        holds a clamped aim, or that is further than a step (whose placement and turn _aim
        then needs), is measured here from its frame's placement."""
        cost = 0.0
        here: list[_Here] = []
        for part, aim in zip(self._goal_parts, self._aimed, strict=True):
            frame, T_goal, along, turning = part
            if aim is T_goal:  # the task holds the goal: its error is the goal's
                along.update()
                turning.update()
                distance, angle = along.error_norm(), turning.error_norm()
                squared, turned = distance * distance, angle * angle
                if squared <= MAX_STEP_M2 and turned <= MAX_STEP_RAD2:
                    cost += squared + ROTATION_WEIGHT * turned
                    here.append(_NEAR)
                    continue
            current = self._wrapper.get_T_world_frame(frame)
            delta = T_goal[:3, 3] - current[:3, 3]
            turn = pin.log3(current[:3, :3].T.dot(T_goal[:3, :3]))
            squared, turned = float(delta.dot(delta)), float(turn.dot(turn))
            cost += squared + ROTATION_WEIGHT * turned
            here.append((current, turn, squared > MAX_STEP_M2 or turned > MAX_STEP_RAD2))
        self._goals_here = here
        if self._torso is not None:  # held at self._torso_goal
            self._torso.update()
            angle = self._torso.error_norm()
            cost += TORSO_WEIGHT * angle * angle
            for along, turning in self._held_parts:  # each task holds its foot's target
                along.update()
                turning.update()
                distance, angle = along.error_norm(), turning.error_norm()
                cost += HELD_MERIT_WEIGHT * (distance * distance + ROTATION_WEIGHT * angle * angle)
        return cost


def _clamped_towards(
    T_current: np.ndarray, T_goal: np.ndarray, rotation: np.ndarray | None = None
) -> np.ndarray:
    """T_goal, or the pose MAX_STEP_M / MAX_STEP_RAD from T_current in its direction
    (`rotation`: log3 of the rotation from T_current to T_goal, when already known)."""
    out = np.array(T_goal, dtype=float)
    delta = T_goal[:3, 3] - T_current[:3, 3]
    distance = math.sqrt(float(delta @ delta))
    if distance > MAX_STEP_M:
        out[:3, 3] = T_current[:3, 3] + delta * (MAX_STEP_M / distance)
    if rotation is None:
        rotation = pin.log3(T_current[:3, :3].T @ T_goal[:3, :3])
    angle = math.sqrt(float(rotation @ rotation))
    if angle > MAX_STEP_RAD:
        out[:3, :3] = T_current[:3, :3] @ pin.exp3(rotation * (MAX_STEP_RAD / angle))
    return out
