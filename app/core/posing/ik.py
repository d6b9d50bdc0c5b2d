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
"""

from __future__ import annotations

import dataclasses
import math
from typing import Literal

import numpy as np
import pinocchio as pin
import placo
from scipy.spatial import ConvexHull, QhullError

from app.core.posing.shortfall import Bounded, Goal, Situation, blockers
from app.core.posing.stance import anchor_on_foot
from app.core.robot.loops import close_loops
from app.core.robot.model import RobotModel
from app.core.robot.urdf_xml import canonical_urdf

Stance = Literal["left", "right", "both"]
REACHED_M = 1e-3
"""A target closer than this (and REACHED_RAD) counts as reached."""
REACHED_RAD = np.deg2rad(0.5)
NEAR_LIMIT_RAD = np.deg2rad(3.0)
COM_PULL_WEIGHT = 1.0
"""While the CoM is outside the support polygon (a hard constraint would make the QP
infeasible), a CoM task this much heavier than the moving foot pulls it in; once inside, the
polygon is a hard constraint."""
LOOP_WEIGHT = 1e7
COM_TARGET_WEIGHT = 10.0
HOLD_WEIGHT = 10.0
"""Weight of the task that holds chosen joints (a built-in motion's arms, waist, head) at their
start angles: far above the posture's, so the IK does not swing an arm to move the CoM."""
DAMPING_MIN = 1e-6
FLOOR_TOLERANCE_M = 1e-4
"""A sole this little below the floor is rounding, not a request to dig in."""
ROTATION_WEIGHT = 0.01
"""[m²/rad²] in the goal cost used to accept steps: 0.1 rad counts like 1 cm."""
MAX_STEP_M = 0.03
MAX_STEP_RAD = 0.3
"""A soft target further than this is approached through intermediate targets (one per QP
step): a far, unreachable target otherwise asks for huge steps at a stretched, near-singular
leg, and the iterations jump between configurations instead of settling."""
OFF_POLYGON = np.array([[1e3, 1e3], [1e3, -1e3], [-1e3, -1e3], [-1e3, 1e3]])
"""Clockwise square [m] that no CoM leaves: the polygon constraint's "off" state."""
POLYGON_CACHE_M = 1e-6
"""Stance soles that moved less than this [m, and rotation-matrix entries] since the support
polygon was computed keep it: solver residue on a held foot (~1e-9 m) never misses the cache,
and the polygon is then at most about this far from the exact one."""
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
ANCHORED_M = 1e-10
"""[m, and rotation-matrix entries] A stance foot this close to its target needs no rigid
correction of the base (most solves end with the held foot within ~1e-12 of it)."""
TORSO_WEIGHT = 1.0
"""[per rad², beside the moving foot's 1 per m²] of the torso hold: tilting the torso by a
degree costs what missing the foot by 17 mm does, so the legs do the work and a lean appears
only for a target the legs cannot reach (then reported: TORSO_TURN_RAD)."""
HELD_MERIT_WEIGHT = 100.0
"""While the torso is held, the held feet's drift from their targets weighs this much in the
goal cost that accepts steps: near the edge of what the legs reach upright, the QP asks for
long steps whose second-order drift of a held foot (the QP holds it to first order only) can
reach centimetres; the rigid correction of the base (_anchor) would then swing the whole
robot by that much."""
TORSO_TURN_RAD = np.deg2rad(5.0)
"""A torso held at an orientation that ends further than this from it is a fold the user did
not ask for: the result is not `reached`."""
OUT_OF_REACH = " target out of reach: closest pose is "
"""The words of the warning a missed target gives (its distance follows)."""
STANCE_WEIGHT = 1e4
"""Stance feet are soft tasks of overwhelming weight rather than hard equalities: with both
feet of a 5-DOF-leg robot (dircon_biped) held, hard 6-D equalities are rank-deficient and
the QP fails, while a consistent soft target is still met to ~1e-9 m."""


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


@dataclasses.dataclass(frozen=True)
class _Ended:
    """Where a solve ended: its configuration (exact bytes), stance, the feet's placements
    there, the support polygon its result was measured in and whether the CoM is inside it."""

    q: bytes
    stance: Stance
    placements: dict[str, np.ndarray]
    polygon: np.ndarray
    com_inside: bool


class WholeBodyIK:
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
        self._foot_settings: dict[str, tuple[str, float]] = {}
        """(priority, weight) each foot task was last configured with."""
        self._pelvis_frame = robot.tree.root
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
        self._goals_here: list[tuple[np.ndarray, np.ndarray, bool]] = []
        """(frame placement, rotation to the goal, whether the goal is further than a step) of
        each soft goal where the goal cost was last computed: the clamped targets of the next
        step start from them."""
        self._hard_stance = True
        """Stance feet are hard equalities unless that proved rank-deficient for this robot."""
        self._soft_goals: list[tuple[placo.FrameTask, str, np.ndarray]] = []
        """(task, frame, target) of soft frame targets, approached at most MAX_STEP per step."""
        self._aimed: list[np.ndarray] = []
        """The target each soft goal's task holds now (its goal, or a clamped one)."""
        self._goal_parts: list[tuple[str, np.ndarray, np.ndarray]] = []
        """(frame, position, rotation) of each soft goal, contiguous."""
        self._held_parts: list[tuple[str, np.ndarray, np.ndarray]] = []
        """(frame, position, rotation) of each held foot's target (in the goal cost with
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

    def support_polygon(self, q: np.ndarray, stance: Stance) -> np.ndarray:
        """Counter-clockwise corners (xy) [m] of the convex hull of the stance soles at q.

        Cached per stance: while the stance soles stay within POLYGON_CACHE_M of where the
        polygon was computed (a drag of the other foot, solver residue along a motion), the
        same polygon is returned without a new hull."""
        pin.framesForwardKinematics(self.robot.model, self._data, q)
        self._placed_q = None
        return self._polygon_here(stance)

    def _polygon_here(
        self, stance: Stance, placements: dict[str, np.ndarray] | None = None
    ) -> np.ndarray:
        """support_polygon at the configuration self._data's frames were last placed at (or of
        the feet at `placements`, by side, when given)."""
        feet = self._stance_feet[stance]
        if placements is None:
            oMf, ids = self._data.oMf, self._foot_ids
            placements = {foot.side: oMf[ids[foot.side]].homogeneous for foot in feet}
        cache = self._polygon_cache
        if cache is not None and cache[0] == stance:
            for foot, T_then in zip(feet, cache[1], strict=True):
                if float(np.abs(placements[foot.side] - T_then).max()) >= POLYGON_CACHE_M:
                    break
            else:
                return cache[2]
        chosen = [placements[foot.side] for foot in feet]
        points = [
            (T[:3, :3] @ foot.sole_corners_m.T + T[:3, 3:4]).T[:, :2]
            for foot, T in zip(feet, chosen, strict=True)
        ]
        polygon = convex_polygon(np.concatenate(points))
        self._polygon_cache = (stance, chosen, polygon)
        return polygon

    def com_margin(self, q: np.ndarray, polygon: np.ndarray) -> float:
        """Signed distance [m] of the CoM's ground projection inside a convex polygon."""
        self._placed_q = None
        return self._margin_of(self.robot.com(q, self._data)[:2], polygon)

    def margin_at(self, com_xy: np.ndarray, polygon: np.ndarray) -> float:
        """Signed distance [m] of a ground point (a CoM's projection, already computed)
        inside a convex polygon."""
        return self._margin_of(np.asarray(com_xy, dtype=float)[:2], polygon)

    def _margin_of(self, com_xy: np.ndarray, polygon: np.ndarray) -> float:
        """Signed distance [m] of a point inside a convex polygon (its edges' inward normals
        kept for the last polygon asked about)."""
        normals, offsets = self._edges(polygon)
        return float((offsets - normals.dot(com_xy)).min())

    def _edges(self, polygon: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(outward unit normals, offsets) of a counter-clockwise polygon's edges: a point p
        is inside when normals·p ≤ offsets (cached for the last polygon asked about)."""
        if self._halfplanes is None or self._halfplanes[0] is not polygon:
            edges = np.roll(polygon, -1, axis=0) - polygon
            normals = (
                np.stack([edges[:, 1], -edges[:, 0]], axis=1)
                / np.linalg.norm(edges, axis=1)[:, None]
            )
            self._halfplanes = (polygon, normals, np.einsum("ij,ij->i", polygon, normals))
        return self._halfplanes[1], self._halfplanes[2]

    def _guard_com(self, polygon: np.ndarray) -> None:
        """Hard CoM-in-polygon constraint once the CoM is inside (the QP stays feasible from
        there, and it stays on for the rest of the solve: switching back and forth chatters);
        while the CoM is outside, a CoM task pulls it towards the polygon's centroid. The
        wrapper's kinematics are at the configuration asked about."""
        if self._polygon_on:
            return
        inside = self._inside_at_start
        self._inside_at_start = None
        if inside is None:
            inside = self._margin_of(np.asarray(self._wrapper.com_world())[:2], polygon) >= 0.0
        self._set_polygon(inside, polygon)
        if inside:
            self._set_com_pull(None)
        else:
            self._set_com_pull(polygon.mean(axis=0))

    def _set_com_pull(self, target_xy: np.ndarray | None) -> None:
        """Pull the CoM towards target_xy with COM_PULL_WEIGHT, or (None) not at all."""
        self._com_pull = self._ground_com_task(
            self._com_pull, target_xy, "com pull", COM_PULL_WEIGHT
        )

    def _ground_com_task(
        self, task: placo.CoMTask | None, target_xy: np.ndarray | None, name: str, weight: float
    ) -> placo.CoMTask | None:
        """A soft task pulling the CoM's ground projection to target_xy, added to the solver
        if it was not there; None (the task removed) when target_xy is None."""
        if target_xy is None:
            if task is not None:
                self._solver.remove_task(task)
            return None
        if task is None:
            task = self._solver.add_com_task(np.zeros(3))
            task.mask.set_axises("xy")
            task.configure(name, "soft", weight)
        task.target_world = np.array([*np.asarray(target_xy, dtype=float)[:2], 0.0])
        return task

    def _set_polygon(self, on: bool, polygon: np.ndarray | None = None) -> None:
        """Make the hard polygon constraint bite (the support polygon) or not (a huge square:
        placo has no cheap on/off for a hard constraint, and removing one is unsafe). Handed
        to placo by _push_polygon, right before a QP, and only when it changed: a solve turns
        it off at its start and on again at its first step, most often to the same polygon."""
        if on and polygon is not None:
            self._polygon_wanted = polygon
        elif not on:
            self._polygon_wanted = OFF_POLYGON
        self._polygon_on = on

    def _push_polygon(self) -> None:
        wanted = self._polygon_wanted
        if wanted is self._polygon_pushed:
            return
        corners = wanted if wanted is OFF_POLYGON else wanted[::-1]  # placo wants clockwise
        self._polygon.polygon = [np.array(p) for p in corners]
        self._polygon_pushed = wanted

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

    def _aim(self, goals: list, aimed: list[np.ndarray]) -> None:
        """Each soft goal's task aimed at its goal, or MAX_STEP towards it when it is further
        (from where the goal cost was last computed)."""
        for i, ((task, _, goal), (current, turn, far)) in enumerate(
            zip(goals, self._goals_here, strict=True)
        ):
            aim = _clamped_towards(current, goal, turn) if far else goal
            if aim is not aimed[i]:
                task.T_world_frame = aim
                aimed[i] = aim

    def _goal_cost(self) -> float:
        """Weighted distance of the soft goals: Σ |Δp|² [m²] + ROTATION_WEIGHT·|Δθ|² [rad²];
        while a torso is held, its turn from the hold (TORSO_WEIGHT·|Δθ|², as in the QP: a
        step that straightens the torso while the foot lags is a step forward) and the held
        feet's drift (HELD_MERIT_WEIGHT)."""
        cost = 0.0
        here = []
        get = self._wrapper.get_T_world_frame
        for frame, position, rotation in self._goal_parts:
            current = get(frame)
            delta = position - current[:3, 3]
            turn = pin.log3(current[:3, :3].T.dot(rotation))
            squared, turned = float(delta.dot(delta)), float(turn.dot(turn))
            cost += squared + ROTATION_WEIGHT * turned
            here.append((current, turn, squared > MAX_STEP_M**2 or turned > MAX_STEP_RAD**2))
        self._goals_here = here
        if self._torso_goal is not None:
            turn = pin.log3(get(self._pelvis_frame)[:3, :3].T.dot(self._torso_goal))
            cost += TORSO_WEIGHT * float(turn.dot(turn))
            for frame, position, rotation in self._held_parts:
                current = get(frame)
                delta = position - current[:3, 3]
                turn = pin.log3(current[:3, :3].T.dot(rotation))
                drift = float(delta.dot(delta)) + ROTATION_WEIGHT * float(turn.dot(turn))
                cost += HELD_MERIT_WEIGHT * drift
        return cost

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
            link = self.robot.foot(side).link
            placed = data.oMf[self.robot.link_frame_ids[link]]
            if float(np.abs(placed.homogeneous - T_target).max()) > ANCHORED_M:
                q = anchor_on_foot(self.robot, q, link, T_target, data, placed)
                pin.framesForwardKinematics(model, data, q)
        self._placed_q = q
        return q

    def _solve_steps(
        self,
        start: np.ndarray,
        polygon: np.ndarray | None,
        stance_sides: tuple[str, ...],
        warnings: list[str],
        max_iterations: int,
        step_tolerance: float,
        stop_when_met: bool = False,
    ) -> tuple[np.ndarray, int]:
        q, iterations = self._iterate(start, polygon, max_iterations, step_tolerance, stop_when_met)
        if polygon is not None and not self._polygon_on:
            # The CoM never got inside: rather than a contorted compromise, show the pose
            # without the polygon and say so.
            warnings.append(
                "the CoM cannot be brought over the support polygon from here "
                "(a leg without ankle roll cannot shift it over one flat foot): shown without it"
            )
            q, iterations = self._iterate(
                start, None, max_iterations, step_tolerance, stop_when_met
            )
        if self.robot.tree.loops:
            q = close_loops(self.robot, q, self._data).q
        q = self._anchor(q, {side: self._feet[side].T_world_frame for side in stance_sides})
        return q, iterations

    def solve(
        self,
        q_start: np.ndarray,
        targets: IkTargets,
        *,
        com_in_support: bool | None = None,
        max_iterations: int = 60,
        step_tolerance: float = 1e-6,
        stop_when_met: bool = False,
    ) -> IkResult:
        """Iterate the QP from q_start towards the targets; never returns NaN.

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
        stance_sides = ("left", "right") if targets.stance == "both" else (targets.stance,)
        wanted = {}
        self._soft_goals = []
        warnings: list[str] = []
        held_in_place = True
        """No stance foot has a target: the stance feet stay where they are, and so does the
        support polygon."""
        for foot in robot.feet:
            given = targets.T_world_left if foot.side == "left" else targets.T_world_right
            held_in_place = held_in_place and (given is None or foot.side not in stance_sides)
            wanted[foot.side] = placements[foot.side] if given is None else np.asarray(given)
            task = self._feet[foot.side]
            if foot.side not in stance_sides:
                aim = _above_floor(wanted[foot.side], foot.sole_corners_m, foot.side, warnings)
                task.T_world_frame = aim
                self._configure_foot(foot.side, "moving")
                self._soft_goals.append((task, foot.link, aim))
                continue
            task.T_world_frame = wanted[foot.side]
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
        self._held_parts = [
            (robot.foot(side).link, wanted[side][:3, 3].copy(), wanted[side][:3, :3].copy())
            for side in stance_sides
        ]
        self._aimed = [goal for _, _, goal in self._soft_goals]
        self._goal_parts = [
            (frame, goal[:3, 3].copy(), goal[:3, :3].copy()) for _, frame, goal in self._soft_goals
        ]
        self._com_target = self._ground_com_task(
            self._com_target, targets.com_xy, "com target", COM_TARGET_WEIGHT
        )
        use_polygon = self.com_in_support if com_in_support is None else com_in_support

        def steps() -> tuple[np.ndarray, int]:
            chosen = polygon if use_polygon else None
            return self._solve_steps(
                start,
                chosen,
                stance_sides,
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
        return self._result(q, iterations, targets, wanted, warnings, kept)

    def _result(
        self,
        q: np.ndarray,
        iterations: int,
        targets: IkTargets,
        wanted: dict[str, np.ndarray],
        warnings: list[str],
        polygon: np.ndarray | None,
    ) -> IkResult:
        """How close q came to the wanted placements (and CoM), its CoM margin (in `polygon`,
        when the stance feet were held where the solve found them; else the polygon at q), the
        joints near a limit: from one forward kinematics pass."""
        robot, data = self.robot, self._data
        if self._placed_q is not q:  # the solve failed: not placed by _anchor
            pin.framesForwardKinematics(robot.model, data, q)
        oMf = data.oMf
        feet = {side: oMf[frame].homogeneous for side, frame in self._foot_ids.items()}
        position_error, orientation_error = {}, {}
        for label, T_target in wanted.items():
            if label == "pelvis":
                T = oMf[robot.link_frame_ids[self._pelvis_frame]].homogeneous
            else:
                T = feet[label]
            delta = T[:3, 3] - T_target[:3, 3]
            position_error[label] = math.sqrt(float(delta.dot(delta)))
            turn = pin.log3(T_target[:3, :3].T.dot(T[:3, :3]))
            orientation_error[label] = math.sqrt(float(turn.dot(turn)))
        reached = all(
            position_error[k] < REACHED_M and orientation_error[k] < REACHED_RAD for k in wanted
        )
        shortfall = [
            f"{k if k == 'pelvis' else k + ' foot'} {position_error[k] * 1000:.1f} mm, "
            f"{np.rad2deg(orientation_error[k]):.1f}° from its target"
            for k in wanted
            if position_error[k] >= REACHED_M or orientation_error[k] >= REACHED_RAD
        ]
        if not reached:
            worst = max(wanted, key=lambda k: position_error[k])
            warnings.append(
                f"{worst}{OUT_OF_REACH}{position_error[worst] * 1000:.1f} mm, "
                f"{np.rad2deg(orientation_error[worst]):.1f}° away"
            )
        if self._torso_goal is not None:
            R = oMf[robot.link_frame_ids[self._pelvis_frame]].rotation
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
        if not reached:
            shortfall += self._blockers(q, targets, wanted)
        self._ended = _Ended(
            q.tobytes(),
            targets.stance,
            feet,
            polygon,
            margin >= 0.0,
        )
        angles = q[self._bounded_q]
        room = np.minimum(angles - self._bounded_lower, self._bounded_upper - angles)
        near: tuple[str, ...] = ()
        if room.size and room.min() < NEAR_LIMIT_RAD:
            near = tuple(
                name
                for name, close in zip(self._bounded_names, room < NEAR_LIMIT_RAD, strict=True)
                if close
            )
        return IkResult(
            q,
            reached,
            iterations,
            position_error,
            orientation_error,
            margin,
            near,
            tuple(warnings),
            tuple(shortfall),
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
            f"held back by {reason}" for reason in blockers(robot.model, self._data, q, situation)
        ]


DEGENERATE_PAD_M = 5e-4
"""Half-size of the square put around each point of a sole without area (a foot whose
geometry is missing, or a line contact): its polygon is then a thin strip, not an error."""


def convex_polygon(points_xy: np.ndarray) -> np.ndarray:
    """Counter-clockwise corners of the convex hull of points (N, 2) [m]; points on a line (or
    one point) give the hull of small squares around them."""
    try:
        hull = ConvexHull(points_xy)
    except QhullError:
        offsets = DEGENERATE_PAD_M * np.array([[1, 1], [1, -1], [-1, -1], [-1, 1]])
        points_xy = (points_xy[:, None, :] + offsets[None]).reshape(-1, 2)
        hull = ConvexHull(points_xy)
    return points_xy[hull.vertices]


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
