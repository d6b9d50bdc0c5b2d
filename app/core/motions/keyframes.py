"""Keyframed motions: task-space keyframes interpolated and re-solved by whole-body IK.

A Keyframe says where the feet, the pelvis and the CoM's ground projection should be, which
feet stand still while it is reached (its `stance`), and how long reaching it takes from the
previous keyframe. `interpolate` samples the motion every dt seconds:

- between consecutive keyframes every target moves with the minimum-jerk time law
  s(τ) = 10τ³ − 15τ⁴ + 6τ⁵, τ = (t − t_start) / duration (zero velocity and acceleration at
  every keyframe): positions p0 + s·(p1 − p0), orientations by slerp R0·exp(s·log(R0ᵀR1)),
  com_xy likewise; or with a trapezoidal speed profile (`profile="trapezoid"`);
- a keyframe with `swing_height_m` > 0 moves its non-stance foot along a semi-ellipse over the
  chord from its previous placement: p = p0 + ½(1 − cos φ)·(p1 − p0) + h·sin φ·ẑ with the
  phase φ = π·s(τ) (the stepping path of the hybrid-leg paper, Sec. 4.1);
- each sample is solved by WholeBodyIK warm-started from the previous sample, with the stance
  feet of the segment held where they stood when it started; a sample that would still slide
  one (the IK's hold is a heavy soft task, and an unreachable CoM target can pull it) is
  solved again without the CoM target, or keeps the previous pose, and says so;
- when a keyframe gives both the pelvis and the CoM, the CoM's ground projection takes
  precedence over the pelvis's horizontal position (the IK weighs it 10×, and the two are only
  consistent at the keyframes): a horizontal pelvis miss is not reported, its height and
  orientation are;
- a foot is in contact when it is a stance foot of the segment, or when its sole's lowest
  corner is within CONTACT_BAND_M of the ground (z = 0);
- no joint moves further in one sample than its speed limit allows: a larger IK step is
  scaled down and the sample flagged (app.core.motions.continuity);
- v and a come from app.core.motions.trajectory.from_configurations (finite differences on the
  configuration manifold, as the spring-compensation paper does, eqs. 19–22).

IK shortfalls (a target out of reach, the CoM outside the support polygon) do not stop the
motion: the closest pose is kept and the warning is reported with its sample (pelvis and
moving feet beyond REPORT_M / REPORT_RAD, the CoM beyond the IK's 1 mm).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Literal

import numpy as np
import pinocchio as pin

from app.core.budgets import check_dt, check_samples
from app.core.errors import StudioError
from app.core.motions.continuity import limit_joint_steps
from app.core.motions.interpolant import Blend, min_jerk, trapezoid
from app.core.motions.result import MotionResult, SampleWarning
from app.core.motions.trajectory import from_configurations
from app.core.posing.ik import IkResult, IkTargets, Stance, WholeBodyIK
from app.core.posing.ready_pose import MOTION_POSTURE_WEIGHT, ready_pose
from app.core.robot.model import RobotModel

Profile = Literal["min_jerk", "trapezoid"]
CONTACT_BAND_M = 1e-3
"""A non-stance foot whose sole is this close to the ground counts as in contact."""
STANCE_TOLERANCE_M = 1e-3
"""A stance foot may differ by this much between the two keyframes of its segment."""
STANCE_SLIDE_M = 5e-4
"""A sample whose stance feet are further than this from where they stood at the start of
the segment is re-solved (see _keep_stance)."""
REPORT_M, REPORT_RAD = 2e-3, np.deg2rad(1.0)
"""A pelvis or moving-foot target missed by less than this is not reported: between
keyframes the interpolated targets are not exactly consistent with each other (only the
keyframes are), and the IK's compromise can leave ~1 mm."""
SOLVE_ITERATIONS = 20
"""IK iterations per sample at most (warm-started, it converges in a few)."""
FIRST_ITERATIONS = 200
"""For the first sample when the first keyframe has no configuration (solved from the ready
pose)."""


class KeyframeError(StudioError):
    """Keyframes that cannot be interpolated (too few, bad durations, NaN, moving stance)."""


@dataclasses.dataclass(frozen=True, eq=False)
class Keyframe:
    """A task-space pose of the robot, and how to reach it from the previous keyframe."""

    name: str
    duration_s: float
    """Time to reach this keyframe from the previous one [s] (unused for the first)."""
    T_world_left: np.ndarray
    """Placement of the left foot link, 4x4 [m]."""
    T_world_right: np.ndarray
    T_world_pelvis: np.ndarray | None = None
    """Placement of the pelvis (root link), 4x4 [m]; None leaves it free."""
    com_xy: np.ndarray | None = None
    """Ground projection of the CoM [m], shape (2,); None leaves it free."""
    stance: Stance = "both"
    """Feet held fixed while this keyframe is reached; the others follow their targets."""
    swing_height_m: float = 0.0
    """Apex of the moving foot's semi-elliptical path above its chord [m]; 0: straight line."""
    profile: Profile = "min_jerk"
    """Time law of the segment reaching this keyframe."""
    q: np.ndarray | None = None
    """The configuration the keyframe was captured from, if any: seeds the IK at the start."""


def capture_keyframe(
    robot: RobotModel, q: np.ndarray, stance: Stance, name: str, duration_s: float, **options
) -> Keyframe:
    """A keyframe holding the feet, pelvis and CoM where they are at configuration q."""
    data = robot.model.createData()
    placements = robot.link_placements(q, data)
    left, right = (placements[foot.link] for foot in robot.feet)
    return Keyframe(
        name=name,
        duration_s=duration_s,
        T_world_left=left,
        T_world_right=right,
        T_world_pelvis=placements[robot.tree.root],
        com_xy=robot.com(q, data)[:2],
        stance=stance,
        q=np.array(q, dtype=float),
        **options,
    )


def validate(keyframes: Sequence[Keyframe]) -> None:
    """Raise KeyframeError naming the first keyframe that cannot be interpolated."""
    if len(keyframes) < 2:
        raise KeyframeError(f"a motion needs at least 2 keyframes, got {len(keyframes)}")
    for i, kf in enumerate(keyframes):
        label = f"keyframe {i} ({kf.name!r})"
        if i > 0 and not (math.isfinite(kf.duration_s) and kf.duration_s > 0.0):
            raise KeyframeError(
                f"{label}: duration {kf.duration_s} s; it must be a positive number of seconds"
            )
        for field in ("T_world_left", "T_world_right", "T_world_pelvis", "com_xy"):
            value = getattr(kf, field)
            shape = (2,) if field == "com_xy" else (4, 4)
            if value is None and field in ("T_world_pelvis", "com_xy"):
                continue
            array = np.asarray(value, dtype=float)
            if array.shape != shape or not np.all(np.isfinite(array)):
                raise KeyframeError(f"{label}: {field} must be {shape} finite numbers")
            if shape == (4, 4) and not np.allclose(
                array[:3, :3].T @ array[:3, :3], np.eye(3), atol=1e-6
            ):
                raise KeyframeError(f"{label}: {field} is not a rigid transform")
        if kf.stance not in ("left", "right", "both"):
            raise KeyframeError(f"{label}: stance {kf.stance!r}; use 'left', 'right' or 'both'")
        if not (math.isfinite(kf.swing_height_m) and kf.swing_height_m >= 0.0):
            raise KeyframeError(f"{label}: swing height {kf.swing_height_m} m must be ≥ 0")
        if i == 0:
            continue
        for side in ("left", "right") if kf.stance == "both" else (kf.stance,):
            moved = np.linalg.norm(_foot(kf, side)[:3, 3] - _foot(keyframes[i - 1], side)[:3, 3])
            if moved > STANCE_TOLERANCE_M:
                raise KeyframeError(
                    f"{label}: the {side} foot stands (stance {kf.stance!r}) but is "
                    f"{moved * 1000:.1f} mm away from where the previous keyframe puts it"
                )


def interpolate(
    robot: RobotModel,
    keyframes: Sequence[Keyframe],
    dt: float = 0.01,
    ik: WholeBodyIK | None = None,
    com_in_support: bool = True,
    name: str = "keyframes",
    held_joints: Sequence[str] = (),
) -> MotionResult:
    """Sample the keyframed motion every dt [s], solving IK at every sample (module docstring).

    Every sample is an IK solution, the first one of the first keyframe's targets, started
    from its captured configuration, or from the robot's ready pose when it has none
    (app.core.posing.ready_pose: from straight legs the IK cannot lower the pelvis). The last
    keyframe is reached at t = Σ durations; samples are at k·dt up to it, and one more
    holding the final targets when the total is not a multiple of dt. Pass `ik` to reuse a
    solver (its own posture weight is then used; see MOTION_POSTURE_WEIGHT). `held_joints`
    stay at their angles of the first sample (a built-in motion's arms: see Plan.held_joints).

    Returns the trajectory with one SampleWarning per IK shortfall per sample.
    """
    validate(keyframes)
    if not (math.isfinite(dt) and dt > 0.0):
        raise KeyframeError(f"time step {dt} s; it must be a positive number of seconds")
    check_dt(dt, "time step")
    total_s = float(sum(kf.duration_s for kf in keyframes[1:]))
    check_samples(total_s / dt + 1, robot.model.nq, f"a {total_s:.6g} s motion at dt {dt:g} s")
    ik = ik or WholeBodyIK(
        robot, com_in_support=com_in_support, posture_weight=MOTION_POSTURE_WEIGHT
    )
    data = robot.model.createData()
    scratch = robot.model.createData()  # for the stance-slide checks, reused every sample
    ends = np.cumsum([0.0] + [kf.duration_s for kf in keyframes[1:]])
    n = math.ceil(float(ends[-1]) / dt - 1e-9) + 1
    first = keyframes[0]
    q = first.q if first.q is not None else ready_pose(robot, ik).q
    if not held_joints:
        qs, contacts, warnings = _sample(
            robot, ik, keyframes, q, dt, n, ends, com_in_support, data, scratch
        )
    else:
        joints = {joint.name: joint for joint in robot.joints}
        ik.hold_joints({name: float(q[joints[name].idx_q]) for name in held_joints})
        try:
            qs, contacts, warnings = _sample(
                robot, ik, keyframes, q, dt, n, ends, com_in_support, data, scratch
            )
        finally:
            ik.hold_joints({})
    trajectory = from_configurations(robot.model, name, robot.joint_names, dt, qs, contacts)
    return MotionResult(trajectory, tuple(warnings))


def _sample(
    robot: RobotModel,
    ik: WholeBodyIK,
    keyframes: Sequence[Keyframe],
    q: np.ndarray,
    dt: float,
    n: int,
    ends: np.ndarray,
    com_in_support: bool,
    data: pin.Data,
    scratch: pin.Data,
) -> tuple[np.ndarray, np.ndarray, list[SampleWarning]]:
    """The samples of `interpolate`: configurations, contacts, warnings."""
    warnings: list[SampleWarning] = []
    first = keyframes[0]
    qs = np.empty((n, robot.model.nq))
    contacts = np.zeros((n, 2), dtype=bool)
    segment, started = 0, -1
    start: dict[str, np.ndarray] = {}
    blends: dict[str, Blend] = {}
    for k in range(n):
        t = k * dt
        while segment + 2 < len(keyframes) and t > ends[segment + 1] + 1e-9:
            segment += 1
        before, after = keyframes[segment], keyframes[segment + 1]
        if segment != started:  # where this segment starts: the previous sample
            started = segment
            start = _where(robot, q, data)
            blends = _blends(before, after, start)
        if k == 0:  # every foot to the first keyframe, so that each sample is an IK solution
            targets = IkTargets(
                first.T_world_left,
                first.T_world_right,
                first.T_world_pelvis,
                first.com_xy,
                after.stance,
            )
        else:
            tau = min(max((t - float(ends[segment])) / after.duration_s, 0.0), 1.0)
            targets = _targets(before, after, tau, after.stance, start, blends)
        targets = _on_floor(robot, targets)
        iterations = SOLVE_ITERATIONS if k > 0 or first.q is not None else FIRST_ITERATIONS
        result = ik.solve(q, targets, com_in_support=com_in_support, max_iterations=iterations)
        messages: list[str] = []
        if k > 0:
            result, messages = _keep_stance(ik, q, targets, result, com_in_support)
            q_next, jump = _continuous(
                robot, ik, q, result.q, start, targets, dt, com_in_support, scratch
            )
            if jump is not None:
                messages.append(jump)
            q = q_next
        else:
            q = result.q
        pin.framesForwardKinematics(robot.model, data, q)
        contacts[k] = _contacts(robot, data, after.stance)
        messages += _shortfalls(robot, data, targets, result, q)
        if com_in_support and result.com_margin_m < 0.0:
            messages.append(f"CoM {-result.com_margin_m * 1000:.1f} mm outside the support polygon")
        warnings += [SampleWarning(k, t, after.name if k else first.name, m) for m in messages]
        qs[k] = q
    return qs, contacts, warnings


def _foot(kf: Keyframe, side: str) -> np.ndarray:
    return np.asarray(kf.T_world_left if side == "left" else kf.T_world_right, dtype=float)


def _blends(before: Keyframe, after: Keyframe, start: dict[str, np.ndarray]) -> dict[str, Blend]:
    """The segment's interpolants, by what they move ("left", "right", "pelvis"): its
    moving feet and, when `after` places it, the pelvis (from `before`'s, or from where it
    was when the segment started)."""
    blends = {
        side: Blend.of(_foot(before, side), _foot(after, side))
        for side in ("left", "right")
        if after.stance not in (side, "both")
    }
    if after.T_world_pelvis is not None:
        T0 = before.T_world_pelvis if before.T_world_pelvis is not None else start["pelvis"]
        blends["pelvis"] = Blend.of(np.asarray(T0), np.asarray(after.T_world_pelvis))
    return blends


def _targets(
    before: Keyframe,
    after: Keyframe,
    tau: float,
    stance: Stance,
    start: dict[str, np.ndarray],
    blends: dict[str, Blend],
) -> IkTargets:
    """IK targets at phase τ of the segment from `before` to `after` (module docstring);
    `start`: where the feet, pelvis and CoM were when the segment started (_where);
    `blends`: the segment's interpolants (_blends)."""
    s = trapezoid(tau) if after.profile == "trapezoid" else min_jerk(tau)
    feet: dict[str, np.ndarray | None] = {}
    for side in ("left", "right"):
        if stance in (side, "both"):
            feet[side] = start[side]  # held where it stood when the segment started
        elif after.swing_height_m > 0.0:
            phase = np.pi * s
            T = blends[side].at(0.5 * (1.0 - np.cos(phase)))
            T[2, 3] += after.swing_height_m * np.sin(phase)
            feet[side] = T
        else:
            feet[side] = blends[side].at(s)
    pelvis = blends["pelvis"].at(s) if "pelvis" in blends else None
    com = None
    if after.com_xy is not None:
        c0 = before.com_xy if before.com_xy is not None else start["com"]
        c0 = np.asarray(c0, dtype=float)
        com = c0 + s * (np.asarray(after.com_xy, dtype=float) - c0)
    return IkTargets(
        T_world_left=feet["left"],
        T_world_right=feet["right"],
        T_world_pelvis=pelvis,
        com_xy=com,
        stance=stance,
    )


def _on_floor(robot: RobotModel, targets: IkTargets) -> IkTargets:
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


def _contacts(robot: RobotModel, data: pin.Data, stance: Stance) -> np.ndarray:
    """(left, right): stance feet, and feet whose sole is within CONTACT_BAND_M of z = 0
    (data holds the frame placements of the sample)."""
    flags = np.zeros(2, dtype=bool)
    for i, foot in enumerate(robot.feet):
        if stance in (foot.side, "both"):
            flags[i] = True
            continue
        T = data.oMf[robot.link_frame_ids[foot.link]]
        lowest = float((T.rotation @ foot.sole_corners_m.T)[2].min() + T.translation[2])
        flags[i] = lowest <= CONTACT_BAND_M
    return flags


def _shortfalls(
    robot: RobotModel, data: pin.Data, targets: IkTargets, result: IkResult, q: np.ndarray
) -> list[str]:
    """The IK's warnings, with its reach check redone (REPORT_M, REPORT_RAD) for the moving
    feet and the pelvis, whose horizontal position yields to a CoM target (not reported then).
    The IK's own reach message is recognised by its wording. `data` holds the frame
    placements at q, the sample kept; when that is the IK's own answer, its measures of the
    feet and of a pelvis without a CoM target are the same numbers and are reused."""
    messages = [m for m in result.warnings if " target out of reach: closest pose" not in m]
    measured = q is result.q
    stance = ("left", "right") if targets.stance == "both" else (targets.stance,)
    for label, link, T_target in (
        ("left", robot.foot("left").link, targets.T_world_left),
        ("right", robot.foot("right").link, targets.T_world_right),
        ("pelvis", robot.tree.root, targets.T_world_pelvis),
    ):
        if T_target is None or label in stance:
            continue
        if measured and (label != "pelvis" or targets.com_xy is None):
            distance = result.position_error_m[label]
            angle = result.orientation_error_rad[label]
        else:
            T = data.oMf[robot.link_frame_ids[link]]
            miss = T.translation - T_target[:3, 3]
            if label == "pelvis" and targets.com_xy is not None:
                miss[:2] = 0.0
            turn = pin.log3(T_target[:3, :3].T @ T.rotation)
            angle = math.sqrt(float(turn.dot(turn)))
            distance = math.sqrt(float(miss.dot(miss)))
        if distance >= REPORT_M or angle >= REPORT_RAD:
            messages.append(
                f"{label} target out of reach: closest pose is {distance * 1000:.1f} mm, "
                f"{np.rad2deg(angle):.1f}° away"
            )
    return messages


def _keep_stance(
    ik: WholeBodyIK,
    q: np.ndarray,
    targets: IkTargets,
    result: IkResult,
    com_in_support: bool,
) -> tuple[IkResult, list[str]]:
    """Make sure a sample does not slide a stance foot from where it stood at the start of
    the segment. When the IK's compromise with an unreachable CoM target moves a held foot
    (its hold is a heavy soft task), the sample is solved again without the CoM target; if a
    foot still slides, the previous pose is kept."""
    slid = _held_miss_m(result, targets.stance)
    if slid <= STANCE_SLIDE_M:
        return result, []
    message = f"the CoM target would slide a standing foot {slid * 1000:.1f} mm"
    if targets.com_xy is not None:
        retry = ik.solve(
            q,
            dataclasses.replace(targets, com_xy=None),
            com_in_support=com_in_support,
            max_iterations=SOLVE_ITERATIONS,
        )
        if _held_miss_m(retry, targets.stance) <= STANCE_SLIDE_M:
            return retry, [f"{message}: solved without it"]
    return dataclasses.replace(result, q=q), [f"{message}: the previous pose is kept"]


def _continuous(
    robot: RobotModel,
    ik: WholeBodyIK,
    q_prev: np.ndarray,
    q_new: np.ndarray,
    start: dict[str, np.ndarray],
    targets: IkTargets,
    dt: float,
    com_in_support: bool,
    scratch: pin.Data,
) -> tuple[np.ndarray, str | None]:
    """q_new with no joint faster than its limit (app.core.motions.continuity). When the
    scaled step slides a stance foot, the standing feet are re-planted by the IK around the
    scaled pose (its pelvis and free foot as targets) and the step scaled again, up to three
    times; if a foot still slides, the previous pose is kept. Returns the flag, if any."""
    q, jump = limit_joint_steps(robot, q_prev, q_new, dt)
    if jump is None:
        return q, None
    for _ in range(3):
        if _slide_m(robot, scratch, start, q, targets.stance) <= STANCE_SLIDE_M:
            return q, jump
        # re-plant the standing feet, keeping the scaled pose's pelvis and free foot
        where = _where(robot, q, robot.model.createData())
        held = {
            side: start[side] if targets.stance in (side, "both") else where[side]
            for side in ("left", "right")
        }
        fix = IkTargets(held["left"], held["right"], where["pelvis"], None, targets.stance)
        solved = ik.solve(q, fix, com_in_support=com_in_support, max_iterations=SOLVE_ITERATIONS)
        q, _ = limit_joint_steps(robot, q_prev, solved.q, dt)
    if _slide_m(robot, scratch, start, q, targets.stance) <= STANCE_SLIDE_M:
        return q, jump
    return q_prev.copy(), f"{jump}; it would slide a standing foot: the previous pose is kept"


def _held_miss_m(result: IkResult, stance: Stance) -> float:
    """How far the stance feet are from their targets in an IK result [m]: during a
    segment their targets are where they stood at its start, so this is _slide_m at result.q,
    measured by the IK's own final forward kinematics."""
    sides = ("left", "right") if stance == "both" else (stance,)
    return max(result.position_error_m[side] for side in sides)


def _slide_m(
    robot: RobotModel,
    scratch: pin.Data,
    start: dict[str, np.ndarray],
    q: np.ndarray,
    stance: Stance,
) -> float:
    """How far the stance feet are at q from where they were at the segment's start [m]
    (`scratch`: pinocchio data to compute in; only the stance feet's frames are placed)."""
    pin.forwardKinematics(robot.model, scratch, q)
    return max(
        float(
            np.linalg.norm(
                pin.updateFramePlacement(
                    robot.model, scratch, robot.link_frame_ids[foot.link]
                ).translation
                - start[foot.side][:3, 3]
            )
        )
        for foot in robot.feet
        if stance in (foot.side, "both")
    )


def _where(robot: RobotModel, q: np.ndarray, data: pin.Data) -> dict[str, np.ndarray]:
    """Placements of the feet ("left", "right") and pelvis, and the CoM's xy ("com"), at q."""
    placements = robot.link_placements(q, data)
    return {
        "left": placements[robot.foot("left").link],
        "right": placements[robot.foot("right").link],
        "pelvis": placements[robot.tree.root],
        "com": robot.com(q, data)[:2],
    }
