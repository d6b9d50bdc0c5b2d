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

The keyframe records and their checks are in app.core.motions.keyframe_records, the checks
and guards on each sample in keyframe_guards.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from app.core.budgets import check_dt, check_samples
from app.core.motions.interpolant import Blend, min_jerk, trapezoid
from app.core.motions.keyframe_guards import (
    CONTACT_BAND_M,
    SOLVE_ITERATIONS,
    _contacts,
    _continuous,
    _keep_stance,
    _shortfalls,
    _where,
)
from app.core.motions.keyframe_records import (
    Keyframe,
    KeyframeError,
    Profile,
    _foot,
    capture_keyframe,
    validate,
)
from app.core.motions.result import MotionResult, SampleWarning
from app.core.motions.trajectory import from_configurations
from app.core.posing.ik import IkTargets, Stance, WholeBodyIK
from app.core.posing.ready_pose import MOTION_POSTURE_WEIGHT, ready_pose
from app.core.robot.model import RobotModel

__all__ = [
    "Keyframe",
    "KeyframeError",
    "MotionResult",
    "Profile",
    "capture_keyframe",
    "interpolate",
    "validate",
]

FIRST_ITERATIONS = 200
"""For the first sample when the first keyframe has no configuration (solved from the ready
pose)."""


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
