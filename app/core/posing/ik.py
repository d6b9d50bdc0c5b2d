"""Whole-body inverse kinematics of a biped: feet, pelvis, CoM in the support polygon.

Built on placo's KinematicsSolver (a QP per step over the configuration increment):
- stance feet are held where they are (they do not slide while the other foot moves) by
  tasks of overwhelming weight (see STANCE_WEIGHT); the moving foot and the pelvis are soft frame tasks, so an unreachable target yields the
  closest pose instead of a failure;
- the CoM's ground projection is kept inside the support polygon (convex hull of the stance
  soles' corners, shrunk by a margin), when that option is on: a hard inequality once inside,
  a pull towards the polygon while outside (see COM_PULL_WEIGHT);
- joint limits are hard; declared loop closures are heavily weighted relative-position tasks,
  polished to numerical precision by app.core.robot.loops;
- a light posture task towards the standing pose keeps the redundancy from wandering;
- the torso (the root link) can be held at an orientation (soft, TORSO_WEIGHT): drag posing
  holds it as it was, so that a foot out of the legs' easy reach does not fold the body.

A result that misses a target, or whose torso turned more than TORSO_TURN_RAD from where it
was held, is not `reached`; its `shortfall` says by how much and what holds it back
(app.core.posing.shortfall: a joint at a limit the targets push against, the CoM polygon, the
torso hold).

Each `solve` iterates the QP from the given configuration until the step vanishes, or (a drag:
stop_when_met) until an accepted step meets the goals to GOAL_MET_COST.

`track` answers a motion's next sample with one QP step from a prediction where that step
converges, and with `solve` otherwise (ik_track).

This module builds the tasks and runs a solve; its parts live beside it: ik_records (targets,
result, shared weights), support_polygon (the polygon and the CoM constraint), ik_steps (the
iterations and their stop rule), ik_verdict (reached or not, and why), ik_track (a motion's
samples).
"""

from __future__ import annotations

from typing import Literal

import numpy as np
import pinocchio as pin
import placo

from app.core.posing.ik_records import (
    COM_TARGET_WEIGHT,
    REACHED_M,
    REACHED_RAD,
    TORSO_WEIGHT,
    IkResult,
    IkTargets,
    Stance,
    _Ended,
)
from app.core.posing.ik_steps import GoalPart, IkStepsMixin
from app.core.posing.ik_track import IkTrackMixin
from app.core.posing.ik_verdict import OUT_OF_REACH, TORSO_TURN_RAD
from app.core.posing.shortfall import Bounded
from app.core.posing.stance import anchor_on_foot
from app.core.posing.support_polygon import OFF_POLYGON
from app.core.robot.loops import close_loops
from app.core.robot.model import RobotModel
from app.core.robot.urdf_xml import canonical_urdf

__all__ = [
    "OUT_OF_REACH",
    "REACHED_M",
    "REACHED_RAD",
    "TORSO_TURN_RAD",
    "TORSO_WEIGHT",
    "IkResult",
    "IkTargets",
    "Stance",
    "WholeBodyIK",
]

LOOP_WEIGHT = 1e7
HOLD_WEIGHT = 10.0
"""Weight of the task that holds chosen joints (a built-in motion's arms, waist, head) at their
start angles: far above the posture's, so the IK does not swing an arm to move the CoM."""
DAMPING_MIN = 1e-6
FLOOR_TOLERANCE_M = 1e-4
"""A sole this little below the floor is rounding, not a request to dig in."""
ANCHORED_M = 1e-10
"""[m, and rotation-matrix entries] A stance foot this close to its target needs no rigid
correction of the base (most solves end with the held foot within ~1e-12 of it)."""
STANCE_WEIGHT = 1e4
"""Stance feet are soft tasks of overwhelming weight rather than hard equalities: with both
feet of a 5-DOF-leg robot (dircon_biped) held, hard 6-D equalities are rank-deficient and
the QP fails, while a consistent soft target is still met to ~1e-9 m."""


class WholeBodyIK(IkStepsMixin, IkTrackMixin):
    """An IK solver bound to one robot. Not thread-safe: one per user of the robot."""

    def __init__(
        self,
        robot: RobotModel,
        *,
        com_in_support: bool = True,
        com_margin_m: float = 0.01,
        posture_weight: float = 1e-5,
    ) -> None:
        self.robot = robot
        self.com_in_support = com_in_support
        self.com_margin_m = com_margin_m
        self.posture_weight = posture_weight
        self._wrapper = placo.RobotWrapper("", 0, canonical_urdf(robot.tree))
        if list(self._wrapper.model.names) != list(robot.model.names):
            raise RuntimeError(
                "placo and pinocchio disagree on the joint order"
            )  # a bug, not input
        self._solver = placo.KinematicsSolver(self._wrapper)
        self._solver.enable_joint_limits(True)
        self._solver.enable_velocity_limits(False)
        self._solver.mask_fbase(not robot.floating_base)
        left, right = (foot.link for foot in robot.feet)
        self._feet = {
            "left": self._solver.add_frame_task(left, np.eye(4)),
            "right": self._solver.add_frame_task(right, np.eye(4)),
        }
        self._foot_parts = {side: (t.position(), t.orientation()) for side, t in self._feet.items()}
        """The position and orientation parts of each foot's task (the goal cost reads them)."""
        self._held_at: dict[str, bytes] = {}
        """The target each held foot's task holds, as bytes (a motion's segment gives the same
        one to every sample: placo is not handed it again)."""
        self._foot_settings: dict[str, tuple[str, float]] = {}
        """(priority, weight) each foot task was last configured with."""
        self._pelvis_frame = robot.tree.root
        self._pelvis_id = robot.link_frame_ids[robot.tree.root]
        self._pelvis: placo.FrameTask | None = None
        """The pelvis task while a solve has a pelvis target (added then, removed after: see
        _com_target)."""
        self._torso: placo.OrientationTask | None = None
        """The torso hold while a solve has one (added then, removed after)..."""
        self._torso_goal: np.ndarray | None = None
        """...and the orientation it holds (also in the goal cost)."""
        self._add_loop_tasks(robot)
        self._bound_joints(robot)
        self._foot_ids = {foot.side: robot.link_frame_ids[foot.link] for foot in robot.feet}
        self._stance_feet = {
            stance: tuple(foot for foot in robot.feet if stance in (foot.side, "both"))
            for stance in ("left", "right", "both")
        }
        self._posture = self._solver.add_joints_task()
        self._posture.configure("posture", "soft", posture_weight)
        self._posture_angles = b""
        """The posture task's target angles, as bytes (a cheap exact comparison)."""
        self._set_posture(robot.q_neutral)
        self._held: placo.JointsTask | None = None
        """The hold on chosen joints while one is set (hold_joints)."""
        self._damping = self._solver.add_regularization_task(DAMPING_MIN)
        self._polygon = self._solver.add_com_polygon_constraint([np.zeros(2)] * 3, com_margin_m)
        self._polygon.configure("com polygon", "hard", 1.0)
        self._polygon_on = False
        self._polygon_wanted: np.ndarray = OFF_POLYGON
        """The polygon the constraint should hold (OFF_POLYGON when off), clockwise..."""
        self._polygon_pushed: np.ndarray | None = None
        """...and the one placo holds: it is handed over only when they differ, before a QP."""
        self._set_polygon(False)
        self._com_pull: placo.CoMTask | None = None
        """The CoM pull while the CoM is being brought into the polygon..."""
        self._com_target: placo.CoMTask | None = None
        """...and the CoM target while a solve has one: tasks a solve does not use are not in
        its QPs at all (a zero-weight task still costs its rows in every QP; placo deletes a
        removed task, so its handle is dropped with it)."""
        self._data = robot.model.createData()
        self._placed_q: np.ndarray | None = None
        """The configuration self._data's frames were last placed at by _anchor."""
        self._ended: _Ended | None = None
        """Where the last solve ended: a solve starting there (the next drag event, the next
        sample of a motion) takes the feet's placements, the support polygon and the CoM's side
        of it from there instead of computing them again."""
        self._inside_at_start: bool | None = None
        """Whether the CoM is inside the polygon at the start of this solve, when known."""
        self._polygon_cache: tuple[str, list[np.ndarray], np.ndarray] | None = None
        """(stance, stance-feet placements, polygon) of the last support polygon computed."""
        self._halfplanes: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        """(polygon, inward edge normals, offsets) of the last polygon a margin was taken in."""
        self._goals_here: list[tuple[np.ndarray | None, np.ndarray | None, bool]] = []
        """(frame placement, rotation to the goal, whether the goal is further than a step) of
        each soft goal where the goal cost was last computed: the clamped targets of the next
        step start from them."""
        self._hard_stance = True
        """Stance feet are hard equalities unless that proved rank-deficient for this robot."""
        self._soft_goals: list[tuple[placo.FrameTask, str, np.ndarray]] = []
        """(task, frame, target) of soft frame targets, approached at most MAX_STEP per step."""
        self._aimed: list[np.ndarray] = []
        """The target each soft goal's task holds now (its goal, or a clamped one)."""
        self._goal_parts: list[GoalPart] = []
        """(frame, target, position task, orientation task) of each soft goal."""
        self._held_parts: list[tuple[placo.PositionTask, placo.OrientationTask]] = []
        """The tasks of each held foot, aimed at its target (its drift is in the goal cost with
        HELD_MERIT_WEIGHT while a torso is held)."""

    def _add_loop_tasks(self, robot: RobotModel) -> None:
        """One relative-position task per kinematic loop of `robot`."""
        for loop in robot.tree.loops:
            task = self._solver.add_relative_position_task(loop.link_a, loop.link_b, np.zeros(3))
            # Soft but dominant: a planar loop's out-of-plane rows are rank-deficient as hard
            # equalities. close_loops() polishes the result to numerical precision.
            task.configure(f"loop {loop.name}", "soft", LOOP_WEIGHT)

    def _bound_joints(self, robot: RobotModel) -> None:
        """The joints with limits (not continuous) and their bounds."""
        bounded = [joint for joint in robot.joints if joint.kind != "continuous"]
        self._bounded_names = tuple(joint.name for joint in bounded)
        self._bounded_q = np.array([joint.idx_q for joint in bounded], dtype=int)
        """Configuration index of each joint with limits (not continuous), in joint order."""
        self._bounded_lower = np.array([joint.lower for joint in bounded], dtype=float)
        self._bounded_upper = np.array([joint.upper for joint in bounded], dtype=float)
        self._bounded_list = [(j.name, j.idx_q, float(j.lower), float(j.upper)) for j in bounded]
        """(name, configuration index, lower, upper) of each, for loops over Python floats."""
        self._bounded_info = Bounded(
            self._bounded_names,
            np.array([joint.idx_v for joint in bounded], dtype=int),
            self._bounded_q,
            self._bounded_lower,
            self._bounded_upper,
        )

    def _configure_foot(self, side: str, role: Literal["moving", "held"]) -> None:
        """A moving foot is a soft task; a held one hard (or of STANCE_WEIGHT once hard stance
        equalities proved rank-deficient). placo is told only of changes."""
        if role == "moving":
            setting = ("soft", 1.0)
        else:
            setting = ("hard", 1.0) if self._hard_stance else ("soft", STANCE_WEIGHT)
        if self._foot_settings.get(side) != setting:
            self._feet[side].configure(side, setting[0], setting[1], setting[1])
            self._foot_settings[side] = setting

    def _set_posture(self, q: np.ndarray) -> None:
        angles = q[self._bounded_q]  # the posture task leaves continuous joints free
        exact = angles.tobytes()
        if exact == self._posture_angles:
            return  # already the posture task's target (a motion's samples: the standing pose)
        self._posture_angles = exact
        self._posture.set_joints(dict(zip(self._bounded_names, angles.tolist(), strict=True)))

    def hold_joints(self, angles: dict[str, float], weight: float = HOLD_WEIGHT) -> None:
        """Hold these joints at these angles [rad] in every solve until called again (a soft
        joints task of `weight`); an empty dict releases the hold."""
        if self._held is not None:
            self._solver.remove_task(self._held)
            self._held = None
        if angles:
            self._held = self._solver.add_joints_task()
            self._held.configure("held joints", "soft", weight)
            self._held.set_joints(dict(angles))

    def _hold_torso(self, R_world: np.ndarray | None) -> None:
        """Hold the torso at R_world (soft, TORSO_WEIGHT), or (None) not at all."""
        if R_world is None:
            if self._torso is not None:
                self._solver.remove_task(self._torso)
                self._torso = None
            self._torso_goal = None
            return
        if self._torso is None:
            self._torso = self._solver.add_orientation_task(self._pelvis_frame, np.eye(3))
            self._torso.configure("torso", "soft", TORSO_WEIGHT)
        self._torso_goal = np.array(R_world, dtype=float)
        self._torso.R_world_frame = self._torso_goal

    def _anchor(self, q: np.ndarray, stance_targets: dict[str, np.ndarray]) -> np.ndarray:
        """Move the floating base rigidly so the first stance foot is exactly on its target.

        The QP's linearised steps can leave a held foot a fraction of a millimetre off after
        a compromise with an unreachable target; a rigid correction of the base removes that
        exactly without changing a joint (the whole robot shifts by the same amount). A foot
        within ANCHORED_M of its target is left as it is. Leaves self._data's frames placed at
        the returned configuration.
        """
        model, data = self.robot.model, self._data
        pin.framesForwardKinematics(model, data, q)
        if self.robot.floating_base and stance_targets:
            side, T_target = next(iter(stance_targets.items()))
            placed = data.oMf[self._foot_ids[side]]
            if float(np.abs(placed.homogeneous - T_target).max()) > ANCHORED_M:
                link = self.robot.foot(side).link
                q = anchor_on_foot(self.robot, q, link, T_target, data, placed)
                pin.framesForwardKinematics(model, data, q)
        self._placed_q = q
        return q

    def _solve_steps(
        self,
        start: np.ndarray,
        polygon: np.ndarray | None,
        held: dict[str, np.ndarray],
        warnings: list[str],
        max_iterations: int,
        step_tolerance: float,
        stop_when_met: bool = False,
    ) -> tuple[np.ndarray, int]:
        """The iterations (without the polygon if the CoM never got in it), loops, anchor."""
        q, iterations = self._iterate(start, polygon, max_iterations, step_tolerance, stop_when_met)
        if polygon is not None and not self._polygon_on:
            # The CoM never got inside: rather than a contorted compromise, show the pose
            # without the polygon and say so.
            warnings.append(
                "the CoM cannot be brought over the support polygon from here (the joints "
                "cannot shift it over the stance sole from this pose): shown without it"
            )
            q, iterations = self._iterate(
                start, None, max_iterations, step_tolerance, stop_when_met
            )
        if self.robot.tree.loops:
            q = close_loops(self.robot, q, self._data).q
        q = self._anchor(q, held)
        return q, iterations

    def _set_tasks(
        self, targets: IkTargets, placements: dict[str, np.ndarray]
    ) -> tuple[dict[str, np.ndarray], tuple[str, ...], list[str], bool]:
        """The tasks set for `targets` (feet held or moving, pelvis, torso hold, CoM target),
        the feet without a target kept at `placements`. Returns (wanted placements by label,
        stance sides, warnings, whether no stance foot has a target: held_in_place)."""
        robot = self.robot
        stance_sides = ("left", "right") if targets.stance == "both" else (targets.stance,)
        wanted = {}
        self._soft_goals = []
        warnings: list[str] = []
        held_in_place = True
        # no stance foot has a target: the stance feet stay where they are, and so does the
        # support polygon
        for foot in robot.feet:
            given = targets.T_world_left if foot.side == "left" else targets.T_world_right
            held_in_place = held_in_place and (given is None or foot.side not in stance_sides)
            wanted[foot.side] = placements[foot.side] if given is None else np.asarray(given)
            task = self._feet[foot.side]
            if foot.side not in stance_sides:
                aim = _above_floor(wanted[foot.side], foot.sole_corners_m, foot.side, warnings)
                task.T_world_frame = aim
                self._held_at.pop(foot.side, None)
                self._configure_foot(foot.side, "moving")
                self._soft_goals.append((task, foot.link, aim))
                continue
            exact = wanted[foot.side].tobytes()
            if exact != self._held_at.get(foot.side):
                task.T_world_frame = wanted[foot.side]
                self._held_at[foot.side] = exact
            self._configure_foot(foot.side, "held")
        if targets.T_world_pelvis is not None:
            wanted["pelvis"] = np.asarray(targets.T_world_pelvis)
            if self._pelvis is None:
                self._pelvis = self._solver.add_frame_task(self._pelvis_frame, np.eye(4))
                self._pelvis.configure("pelvis", "soft", 1.0, 1.0)
            self._pelvis.T_world_frame = wanted["pelvis"]
            self._soft_goals.append((self._pelvis, self._pelvis_frame, wanted["pelvis"]))
        elif self._pelvis is not None:
            self._solver.remove_task(self._pelvis)
            self._pelvis = None
        self._hold_torso(None if targets.T_world_pelvis is not None else targets.R_world_torso)
        self._com_target = self._ground_com_task(
            self._com_target, targets.com_xy, "com target", COM_TARGET_WEIGHT
        )
        return wanted, stance_sides, warnings, held_in_place

    def solve(
        self,
        q_start: np.ndarray,
        targets: IkTargets,
        *,
        com_in_support: bool | None = None,
        max_iterations: int = 60,
        step_tolerance: float = 1e-6,
        stop_when_met: bool = False,
        explain: bool = True,
    ) -> IkResult:
        """Iterate the QP from q_start towards the targets; never returns NaN.

        explain=False leaves out of the result's shortfall what holds a pose back (a
        motion's samples report their misses without it).

        stop_when_met: stop at the first step the line search accepts with the goals met to
        GOAL_MET_COST (the moving foot within 0.1 mm and 1 mrad of its target, the torso hold
        within 0.1 mrad, the held feet within 10 µm) instead of iterating until the steps
        vanish: the steps from there trade the light posture task against the goals below
        what is visible, and most are refused by the line search anyway (a drag event: one
        QP where the full convergence test takes two or three); also at a small accepted step
        that lowers a goal cost already below CRAWL_COST by less than CRAWL_GAIN (a crawl along
        an active constraint). Only for solves whose soft goals are all in the goal cost (no CoM
        target, no joint hold): a drag."""
        robot = self.robot
        start = np.array(q_start, dtype=float)
        self._placed_q = None
        self._set_posture(robot.q_neutral if targets.posture_q is None else targets.posture_q)
        ended = self._ended
        if ended is not None and ended.stance == targets.stance and ended.q == start.tobytes():
            placements, polygon = ended.placements, ended.polygon
            self._inside_at_start = ended.com_inside
        else:
            pin.framesForwardKinematics(robot.model, self._data, start)
            placements = {
                side: self._data.oMf[frame].homogeneous for side, frame in self._foot_ids.items()
            }
            polygon = self._polygon_here(targets.stance, placements)
            self._inside_at_start = None
        wanted, stance_sides, warnings, held_in_place = self._set_tasks(targets, placements)
        self._held_parts = [self._foot_parts[side] for side in stance_sides]
        self._aimed = [goal for _, _, goal in self._soft_goals]
        self._goal_parts = [
            (frame, goal, task.position(), task.orientation())
            for task, frame, goal in self._soft_goals
        ]
        use_polygon = self.com_in_support if com_in_support is None else com_in_support
        held = {side: wanted[side] for side in stance_sides}  # what their tasks hold

        def steps() -> tuple[np.ndarray, int]:
            chosen = polygon if use_polygon else None
            return self._solve_steps(
                start,
                chosen,
                held,
                warnings,
                max_iterations,
                step_tolerance,
                stop_when_met and targets.com_xy is None and self._held is None,
            )

        try:
            try:
                q, iterations = steps()
            except RuntimeError:
                if not self._hard_stance:
                    raise
                # Hard 6-D stance equalities are rank-deficient for legs with fewer than six
                # joints (dircon_biped with both feet down): hold the feet by weight instead.
                self._hard_stance = False
                for side in stance_sides:
                    self._configure_foot(side, "held")
                q, iterations = steps()
        except (RuntimeError, FloatingPointError) as error:
            warnings.append(f"IK step failed ({error}); the pose was kept")
            q, iterations = start, 0
        kept = polygon if held_in_place else None
        return self._result(q, iterations, targets, wanted, warnings, kept, explain)


def _above_floor(
    T_goal: np.ndarray, sole_corners_m: np.ndarray, side: str, warnings: list[str]
) -> np.ndarray:
    """The goal raised so that no sole corner is below the floor (z = 0), with a warning."""
    lowest = float((sole_corners_m @ T_goal[2, :3]).min()) + float(T_goal[2, 3])
    if lowest >= -FLOOR_TOLERANCE_M:
        return T_goal
    raised = np.array(T_goal, dtype=float)
    raised[2, 3] -= lowest
    warnings.append(
        f"{side} foot target is {-lowest * 1000:.0f} mm below the floor: aiming for the floor instead"
    )
    return raised
