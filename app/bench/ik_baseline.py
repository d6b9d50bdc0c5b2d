"""Bench entry "drag_ik": the whole-body IK per drag event beside placo's own loop on the same
problem, stopped at the studio's own final foot error.

The events are the drag entry's (app.bench.posing): the left foot around a 3 cm circle, 2 cm
up, from the pose the studio shows after loading the robot, each event starting from the pose
the previous one returned. They are replayed through a fresh Posing (the studio's IK, as a
drag calls it); for each event the baseline is placo's KinematicsSolver on the same problem —
the left foot soft to the target, the right foot held hard where it is, the torso held at the
gesture's start orientation, the light posture task towards the gesture's start, the damping
task, the CoM kept in the right sole's polygon, the loop closures — from the configuration the
studio's IK starts from, taking QP steps (placo applying each) until the left foot is as close
to its target as the studio's IK left it (position and orientation, "reached"). placo's
steps do not always pass that close: the studio's IK stops where its goal cost (the feet, the
torso) stops falling, while placo's steps go on to the fixed point of the QP, where the light
posture task, pulling against the CoM polygon, holds the foot a few hundredths of a
millimetre further off. So placo's loop also stops at the first step that takes the foot
further from the target ("receding") or when its steps vanish (|dq| < 1e-6, "converged"):
it gets no closer after either. The figures (p50, p95) are over the events where placo's loop
reached the studio's accuracy, both sides on the same events; the note counts the others
(on Roban S14, placo's bare steps oscillate where the studio's IK clamps and line-searches
them) and gives both sides over all events.

Equal accuracy is the point: placo's loop run to |dq| < 1e-6 does more steps than the studio
needs for the same answer. Both are timed in thread CPU, in alternating passes of tight loops
(a busy moment hits one pass, not the comparison), best of the passes per event; the first
WARM_UP_EVENTS are left out (they lift the foot from the ground).

pink and mink (other task-space IK libraries) are not in the studio's environment: no
baseline of theirs is measured.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pinocchio as pin

from app.bench.posing import WARM_UP_EVENTS, _PlacoBareDrag, drag_target, left_foot_placement
from app.bench.registry import BenchContext, bench_entry
from app.bench.report import Figure
from app.bench.timing import THREAD_CPU, percentiles_ms, timed_each
from app.core.posing.drag import Posing
from app.core.robot.model import RobotModel

PASSES = 3
MAX_STEPS = 60
"""placo's loop stops here at the latest (placo's examples' cap, and the studio's)."""
VANISHING_STEP = 1e-6
"""|dq| below which placo's loop has converged: where its answer (the fixed point of its
steps) is not as close to the target as the studio's, it stops there, getting no closer."""


@dataclasses.dataclass(frozen=True)
class DragEvent:
    """One drag event and what the studio's IK made of it."""

    q_before: np.ndarray
    """The pose the event arrives at (the previous event's answer)."""
    target: np.ndarray
    """T_world_target of the left foot, 4 × 4."""
    q_from: np.ndarray
    """Where the studio's IK starts: q_before, or the gesture's start (knees bent) on its
    first event."""
    posture_q: np.ndarray
    R_world_torso: np.ndarray
    polygon: np.ndarray
    """The right sole's support polygon at q_from, counter-clockwise (xy) [m]."""
    position_error_m: float
    """The studio's final distance of the left foot to the target."""
    orientation_error_rad: float


def drag_events(robot: RobotModel, q0: np.ndarray, start: np.ndarray, n: int) -> list[DragEvent]:
    """The n events of the drag entry's circle from q0 (start: the left foot's placement
    there), through a fresh Posing, and what it made of each."""
    posing = Posing(robot)
    events, q = [], q0.copy()
    for k in range(n):
        target = drag_target(start, k, 50)
        result = posing.drag(q, "left", target)
        gesture = posing._gesture
        assert gesture is not None and gesture.R_world_torso is not None
        # A new gesture (the first event) starts from its own q_start, as Posing.drag does.
        q_from = gesture.q_start if k == 0 else q
        events.append(
            DragEvent(
                q_before=q.copy(),
                target=target,
                q_from=q_from.copy(),
                posture_q=gesture.q_start.copy(),
                R_world_torso=gesture.R_world_torso.copy(),
                polygon=posing.ik.support_polygon(q_from, "right"),
                position_error_m=result.position_error_m["left"],
                orientation_error_rad=result.orientation_error_rad["left"],
            )
        )
        q = result.q
    return events


@dataclasses.dataclass(frozen=True)
class Stop:
    """Where placo's loop stopped on an event."""

    steps: int
    ending: str
    """"reached" (as close as the studio's answer), "converged" (|dq| < VANISHING_STEP),
    "receding" (a step took the foot further from the target) or "cap" (MAX_STEPS)."""
    position_error_m: float
    orientation_error_rad: float


class PlacoLoop(_PlacoBareDrag):
    """placo's own IK on a drag event's problem (the module docstring), bare: no Python of
    ours between its QP steps but the stopping test. The drag entry's bare problem (feet,
    posture, damping, loops, CoM polygon) with the torso hold a foot drag adds."""

    def __init__(self, robot: RobotModel) -> None:
        from app.core.posing.ik import TORSO_WEIGHT

        super().__init__(robot)
        self.wrapper, self.solver = self._wrapper, self._solver
        self.left, self.right = self._left, self._right
        self._torso = self.solver.add_orientation_task(robot.tree.root, np.eye(3))
        self._torso.configure("torso", "soft", TORSO_WEIGHT)

    def solve(self, event: DragEvent) -> Stop:  # type: ignore[override]
        """QP steps from the event's start until the left foot is within the studio's final
        errors of the target, or gets no closer (the module docstring), or MAX_STEPS."""
        wrapper, solver = self.wrapper, self.solver
        assert self._posture is not None and self._polygon is not None  # the same problem
        self._polygon.polygon = [np.array(corner) for corner in event.polygon[::-1]]  # clockwise
        wrapper.state.q = event.q_from.copy()
        wrapper.update_kinematics()
        self._posture.set_joints(
            {joint.name: float(event.posture_q[joint.idx_q]) for joint in self._bounded}
        )
        self._torso.R_world_frame = event.R_world_torso
        self._right_task.T_world_frame = wrapper.get_T_world_frame(self.right)
        self._left_task.T_world_frame = event.target
        position, rotation = event.target[:3, 3], event.target[:3, :3]
        distance = turn = math.inf
        ending = "cap"
        for steps in range(1, MAX_STEPS + 1):  # noqa: B007 - returned
            dq = solver.solve(True)
            wrapper.update_kinematics()
            T = wrapper.get_T_world_frame(self.left)
            before, distance = distance, float(np.linalg.norm(T[:3, 3] - position))
            turn = float(np.linalg.norm(pin.log3(rotation.T @ T[:3, :3])))
            if distance <= event.position_error_m and turn <= event.orientation_error_rad:
                ending = "reached"
            elif float(np.linalg.norm(dq)) < VANISHING_STEP:
                ending = "converged"
            elif distance > before:
                ending = "receding"
            else:
                continue
            break
        return Stop(steps, ending, distance, turn)


def ik_beside_placo(robot: RobotModel, events: list[DragEvent], passes: int = PASSES) -> dict:
    """The studio's IK (a fresh Posing, the events' own poses) and placo's loop on each event,
    in alternating passes: CPU [ms] p50 / p95 of each, best of the passes per event, and how
    many steps placo's loop took."""
    posing, loop = Posing(robot), PlacoLoop(robot)
    ours = np.full((passes, len(events)), np.inf)
    theirs = np.full((passes, len(events)), np.inf)
    stops: list[Stop] = []
    for k in range(passes):
        ours[k] = timed_each(
            lambda event: posing.drag(event.q_before, "left", event.target), events, THREAD_CPU
        )
        stops = []
        for i, event in enumerate(events):
            begin = THREAD_CPU()
            stops.append(loop.solve(event))
            theirs[k, i] = THREAD_CPU() - begin
    skip = slice(WARM_UP_EVENTS, None)
    kept, ends = events[skip], stops[skip]
    ours_s, theirs_s = ours.min(axis=0)[skip], theirs.min(axis=0)[skip]
    endings = [stop.ending for stop in ends]
    same = np.array([ending == "reached" for ending in endings])
    return {
        "events": len(kept),
        "equal_accuracy_events": int(same.sum()),
        **_percentiles_or_nan(ours_s[same], "studio_"),
        **_percentiles_or_nan(theirs_s[same], "placo_"),
        **percentiles_ms(ours_s, "all_studio_"),
        **percentiles_ms(theirs_s, "all_placo_"),
        "placo_steps_median": float(np.median([stop.steps for stop in ends])),
        "placo_endings": {name: endings.count(name) for name in sorted(set(endings))},
        "placo_position_error_median_m": float(np.median([s.position_error_m for s in ends])),
        "studio_position_error_median_m": float(np.median([e.position_error_m for e in kept])),
        "studio_orientation_error_median_rad": float(
            np.median([e.orientation_error_rad for e in kept])
        ),
    }


def _percentiles_or_nan(seconds: np.ndarray, prefix: str) -> dict[str, float]:
    if len(seconds):
        return percentiles_ms(seconds, prefix)
    return {f"{prefix}p{p}_ms": float("nan") for p in (50, 95)}


def bench_drag_ik(ctx: BenchContext, source: str, repeats: int) -> dict:
    """The drag entry's events on `source` (loaded in the studio, from its shown pose)."""
    studio = ctx.studio
    studio.robots.load(source)
    robot = studio.state.robot
    assert robot is not None
    events = drag_events(robot, studio.state.q.copy(), left_foot_placement(studio), repeats)
    return ik_beside_placo(robot, events)


@bench_entry("drag_ik")
def _entry_drag_ik(ctx: BenchContext) -> tuple[dict, list[Figure]]:
    rows, figures = {}, []
    for name, source in ctx.robots().items():
        row = bench_drag_ik(ctx, source, ctx.repeats)
        rows[name] = row
        others = ", ".join(
            f"{ending} {count}"
            for ending, count in row["placo_endings"].items()
            if ending != "reached"
        )
        for p in (50, 95):
            note = (
                f"the {row['equal_accuracy_events']} of {row['events']} events where placo's "
                f"loop gets as close as the studio (placo {row['placo_steps_median']:.0f} "
                f"steps, median); on the others it ends further off ({others or 'none'}); on "
                f"all events studio {row[f'all_studio_p{p}_ms']:.3f} ms, placo "
                f"{row[f'all_placo_p{p}_ms']:.3f} ms; pink / mink not installed: not measured"
            )
            figures.append(
                Figure(
                    f"drag: the whole-body IK per event, {name} (CPU, p{p}, equal accuracy)",
                    row[f"studio_p{p}_ms"],
                    "ms",
                    "",
                    None,
                    row[f"placo_p{p}_ms"],
                    "placo's own loop on the same problem, events and start, stopped at the "
                    f"studio's final foot error (CPU, p{p})",
                    note,
                )
            )
    return rows, figures
