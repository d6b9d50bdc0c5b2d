"""A keyframed motion sampled with the trimmed IK (one QP step from a prediction where that
converges, WholeBodyIK.track; solve otherwise) at its nodes and the samples between filled
(app.core.motions.keyframe_fill), against references of its own, sample by sample:

- placo's own plain iteration of each sample's problem (the same targets, stance, posture,
  damping and CoM polygon; no Python of ours in its loop) from the sample before, run until
  |dq| < 1e-11: every sample, solved or filled, must be within SAME_Q of the configuration
  those iterations converge to (each sample is compared from the same start, so nothing
  accumulates);
- pinocchio's frame placements and centre of mass: every sample reaches its targets (the motion
  reports no shortfall, rightly) and its contacts are its stance feet and the feet on the
  ground.

Each sample's targets are recorded where the motion makes them (segment_targets, wrapped).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import placo

from app.core.motions import keyframe_samples
from app.core.motions.keyframe_guards import CONTACT_BAND_M
from app.core.motions.keyframes import interpolate
from app.core.motions.library import MOTIONS, resolve_params
from app.core.posing.ik import REACHED_M, REACHED_RAD, IkResult, IkTargets, WholeBodyIK
from app.core.posing.ready_pose import MOTION_POSTURE_WEIGHT
from app.core.robot.loading import load_robot
from app.core.robot.urdf_xml import canonical_urdf
from tests.core.foot_drags import placo_solve_of

SAME_Q = 1e-5
"""[rad, m] per configuration entry: one Gauss–Newton step from within 1e-3 leaves ~1e-6, and
solve stops once the steps left are predicted below 1e-6 in norm (servo_biped: 2.4e-6 at most
over the squats' 950 samples); a filled sample's estimated error is below 1e-6 (FILL_Q)."""


class _Recording(WholeBodyIK):
    """The IK, keeping each sample's question and answer: (start, targets, result) of every
    outermost solve or track."""

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.asked: list[tuple[np.ndarray, IkTargets, IkResult]] = []
        self._depth = 0

    def _kept(self, answer, q_start, targets, *args, **kwargs) -> IkResult:
        self._depth += 1
        try:
            result = answer(q_start, targets, *args, **kwargs)
        finally:
            self._depth -= 1
        if self._depth == 0:
            self.asked.append((np.array(q_start), targets, result))
        return result

    def solve(self, q_start, targets, *args, **kwargs) -> IkResult:
        return self._kept(super().solve, q_start, targets, *args, **kwargs)

    def track(self, q_from, targets, *args, **kwargs) -> IkResult:
        return self._kept(super().track, q_from, targets, *args, **kwargs)


def test_every_sample_of_the_one_leg_squats_is_placos_own_fixed_point_and_reaches_its_targets(
    monkeypatch,
):
    robot = load_robot("servo_biped")
    plan = MOTIONS["one_leg_squats"].build(robot, **resolve_params("one_leg_squats", {}))
    ik = _Recording(robot, com_in_support=True, posture_weight=MOTION_POSTURE_WEIGHT)
    planned: dict[int, IkTargets] = {}
    made = keyframe_samples._segment

    def recorded(robot, keyframes, segment, start, k, *args):
        targets = made(robot, keyframes, segment, start, k, *args)
        for i, sample_targets in enumerate(targets):  # a segment's from the sample before it
            planned.setdefault(k + i, sample_targets)
        return targets

    monkeypatch.setattr(keyframe_samples, "_segment", recorded)
    motion = interpolate(robot, plan.keyframes, dt=0.01, ik=ik)
    q, contacts = motion.trajectory.q, motion.trajectory.contacts
    assert motion.warnings == ()
    assert sorted(planned) == list(range(len(q))) and len(q) > 900
    # the point of the fill: the IK answers for under half of the samples, each kept as it is
    solved = {}
    for q_start, targets, result in ik.asked:
        k = int(np.flatnonzero((q == result.q).all(axis=1))[0])
        if k > 0:  # from one of the three samples before (the node before, or the sample)
            assert targets is planned[k], k
            assert any(np.array_equal(q_start, q[j]) for j in range(max(k - 3, 0), k)), k
        solved[k] = targets
    assert 0 in solved and len(solved) == len(ik.asked) < 0.5 * len(q)
    wrapper = placo.RobotWrapper("", 0, canonical_urdf(robot.tree))
    data = robot.model.createData()
    for k in range(len(q)):
        targets = solved[0] if k == 0 else planned[k]
        if k > 0:
            fixed, iterations = placo_solve_of(robot, ik, q[k - 1], targets, wrapper)
            assert iterations < 50, k  # no crawl: the comparison holds on every sample
            assert np.abs(q[k] - fixed).max() < SAME_Q, k
        pin.framesForwardKinematics(robot.model, data, q[k])
        stance = ("left", "right") if targets.stance == "both" else (targets.stance,)
        for i, (foot, T_target) in enumerate(
            zip(robot.feet, (targets.T_world_left, targets.T_world_right), strict=True)
        ):
            T = data.oMf[robot.model.getFrameId(foot.link, pin.BODY)]
            assert T_target is not None
            assert np.linalg.norm(T.translation - T_target[:3, 3]) < REACHED_M, k
            assert np.linalg.norm(pin.log3(T_target[:3, :3].T @ T.rotation)) < REACHED_RAD, k
            lowest = float((T.rotation @ foot.sole_corners_m.T)[2].min() + T.translation[2])
            assert contacts[k, i] == (foot.side in stance or lowest <= CONTACT_BAND_M), k
        if targets.com_xy is not None:
            com = pin.centerOfMass(robot.model, data, q[k])[:2]
            assert np.linalg.norm(com - np.asarray(targets.com_xy)[:2]) < REACHED_M, k
