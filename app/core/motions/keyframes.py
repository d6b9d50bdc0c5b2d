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
  feet of the segment held where they stood when it started: one QP step from the previous
  solution moved on by the previous sample's motion where that step is short and reaches the
  targets (WholeBodyIK.track: app.core.posing.ik_track), else iterated to convergence as
  `tracking=False` does for every sample; a sample that would still slide one (the IK's
  hold is a heavy soft task, and an unreachable CoM target can pull it) is solved again
  without the CoM target, or keeps the previous pose, and says so;
- except that, tracking, the IK solves only every FILL_EVERY-th sample of a segment (its
  nodes, each from the node before) and the samples between are filled by the polynomial
  through the nodes around them and checked in one pass (the estimated fill error, the feet,
  pelvis and CoM against their targets, the CoM polygon, joint and speed limits): an
  interval that fails is solved sample by sample, and so is a segment from a node that says
  anything or misses a target (app.core.motions.keyframe_samples, keyframe_fill);
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

The keyframe records and their checks are in app.core.motions.keyframe_records, the targets of
a segment's samples in keyframe_targets, the checks and guards on each sample in
keyframe_guards, the sampling in keyframe_samples and the fill in keyframe_fill.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from app.core.budgets import check_dt, check_samples
from app.core.motions.keyframe_fill import FILL_EVERY
from app.core.motions.keyframe_records import (
    Keyframe,
    KeyframeError,
    Profile,
    capture_keyframe,
    validate,
)
from app.core.motions.keyframe_samples import sample_motion
from app.core.motions.result import MotionResult
from app.core.motions.trajectory import from_configurations
from app.core.posing.ik import WholeBodyIK
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


def interpolate(
    robot: RobotModel,
    keyframes: Sequence[Keyframe],
    dt: float = 0.01,
    ik: WholeBodyIK | None = None,
    com_in_support: bool = True,
    name: str = "keyframes",
    held_joints: Sequence[str] = (),
    tracking: bool = True,
    fill_every: int = FILL_EVERY,
) -> MotionResult:
    """Sample the keyframed motion every dt [s] by IK (module docstring).

    Every sample is an IK solution (a filled one within the fill's checks of one), the first
    one of the first keyframe's targets, started from its captured configuration, or from the
    robot's ready pose when it has none (app.core.posing.ready_pose: from straight legs the IK
    cannot lower the pelvis). The last
    keyframe is reached at t = Σ durations; samples are at k·dt up to it, and one more
    holding the final targets when the total is not a multiple of dt. Pass `ik` to reuse a
    solver (its own posture weight is then used; see MOTION_POSTURE_WEIGHT). `held_joints`
    stay at their angles of the first sample (a built-in motion's arms: see Plan.held_joints).
    `tracking`: each sample after the first is one QP step from a prediction where that
    converges (WholeBodyIK.track); False solves every sample to convergence (WholeBodyIK.solve:
    the reference the tracking is tested and timed against). `fill_every`: while tracking, the
    IK solves every this many samples and the samples between are filled and checked (module
    docstring); 1 solves every sample.

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
    ends = np.cumsum([0.0] + [kf.duration_s for kf in keyframes[1:]])
    n = math.ceil(float(ends[-1]) / dt - 1e-9) + 1
    first = keyframes[0]
    q = first.q if first.q is not None else ready_pose(robot, ik).q
    if not held_joints:
        qs, contacts, warnings = sample_motion(
            robot, ik, keyframes, q, dt, n, ends, com_in_support, tracking, fill_every
        )
    else:
        joints = {joint.name: joint for joint in robot.joints}
        ik.hold_joints({name: float(q[joints[name].idx_q]) for name in held_joints})
        try:
            qs, contacts, warnings = sample_motion(
                robot, ik, keyframes, q, dt, n, ends, com_in_support, tracking, fill_every
            )
        finally:
            ik.hold_joints({})
    trajectory = from_configurations(robot.model, name, robot.joint_names, dt, qs, contacts)
    return MotionResult(trajectory, tuple(warnings))
