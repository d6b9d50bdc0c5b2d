"""A keyframed motion sampled with the trimmed IK equals the same motion sampled with the IK
as it was before (tests/oracles/previous_ik.py, unchanged): same contacts, same warnings, and
samples within SAME_Q. They are not bit-identical: the previous IK's line search sometimes
stopped up to 1e-4 short of the configuration its iterations converge to, where the trimmed
one goes on (tests/core/test_ik_trimmed.py compares both with placo's own converged loop), and
each sample starts from the one before. The previous IK solves every sample (tracking=False:
it has no `track`), behind the call interpolate makes now (_PreviousIk)."""

from __future__ import annotations

import dataclasses

import numpy as np

from app.core.motions.keyframes import interpolate
from app.core.motions.library import MOTIONS, resolve_params
from app.core.posing.ik import IkResult, WholeBodyIK
from app.core.posing.ready_pose import MOTION_POSTURE_WEIGHT
from app.core.robot.loading import load_robot
from tests.oracles import previous_ik

SAME_Q = 1e-3
"""[rad, m] per configuration entry (0.06°), over ~950 samples each started from the one
before."""


class _PreviousIk(previous_ik.WholeBodyIK):
    """The previous IK answering solve's `explain` (ignored: it had no shortfall) with the
    result record interpolate reads now (no placements: interpolate measures them itself)."""

    def solve(self, q_start, targets, *, explain=True, **options):
        return IkResult(**dataclasses.asdict(super().solve(q_start, targets, **options)))


def test_the_one_leg_squats_sample_as_with_the_previous_ik():
    robot = load_robot("servo_biped")
    plan = MOTIONS["one_leg_squats"].build(robot, **resolve_params("one_leg_squats", {}))
    new = interpolate(
        robot,
        plan.keyframes,
        dt=0.01,
        ik=WholeBodyIK(robot, com_in_support=True, posture_weight=MOTION_POSTURE_WEIGHT),
    )
    old = interpolate(
        robot,
        plan.keyframes,
        dt=0.01,
        ik=_PreviousIk(  # type: ignore[arg-type]
            robot, com_in_support=True, posture_weight=MOTION_POSTURE_WEIGHT
        ),
        tracking=False,
    )
    assert new.trajectory.q.shape == old.trajectory.q.shape
    assert np.abs(new.trajectory.q - old.trajectory.q).max() < SAME_Q
    assert np.array_equal(new.trajectory.contacts, old.trajectory.contacts)
    assert [w.message for w in new.warnings] == [w.message for w in old.warnings]
