"""Keyframed motions begin each sample's IK at the last step repeated (q_k-1 ⊕ (q_k-1 ⊖ q_k-2),
while the last two samples were clean); the reference is the same motion sampled with the
same IK begun at the previous sample, as it was before. The IK's fixed point does not depend
on where its iterations begin, so the two motions are the same: same contacts and warnings,
configurations within SAME_Q (the guess only stops the iterations at a different residue
below the IK's 1e-6 tolerance; along the posture's weakest directions a residue drifts
between samples), in fewer QP steps."""

from __future__ import annotations

import numpy as np
import pytest

from app.core.motions.keyframes import interpolate
from app.core.motions.library import MOTIONS, resolve_params
from app.core.posing.ik import WholeBodyIK
from app.core.posing.ready_pose import MOTION_POSTURE_WEIGHT
from app.core.robot.loading import load_robot

SAME_Q = 1e-3
"""[rad, m] per configuration entry, as in tests/core/test_keyframes_trimmed.py."""


class _CountingIK(WholeBodyIK):
    """The real solver, its QP steps counted; `use_guess=False` drops the guess."""

    def __init__(self, *args, use_guess: bool, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.use_guess, self.steps, self.guessed = use_guess, 0, 0

    def solve(self, *args, guess=None, **kwargs):
        self.guessed += guess is not None
        result = super().solve(*args, guess=guess if self.use_guess else None, **kwargs)
        self.steps += result.iterations
        return result


@pytest.mark.parametrize(
    ("robot_name", "motion"),
    [
        ("servo_biped", "one_leg_squats"),
        ("servo_biped", "step_in_place"),
        ("dircon_biped", "com_shift"),
        ("hybrid_leg_biped", "com_shift"),
    ],
)
def test_a_guessed_start_samples_the_same_motion_in_fewer_steps(robot_name, motion):
    robot = load_robot(robot_name)
    plan = MOTIONS[motion].build(robot, **resolve_params(motion, {}))
    runs = {}
    for use_guess in (False, True):
        ik = _CountingIK(
            robot, com_in_support=True, posture_weight=MOTION_POSTURE_WEIGHT, use_guess=use_guess
        )
        runs[use_guess] = (interpolate(robot, plan.keyframes, dt=0.01, ik=ik), ik)
    (plain, plain_ik), (guessed, guessed_ik) = runs[False], runs[True]
    assert np.abs(guessed.trajectory.q - plain.trajectory.q).max() < SAME_Q
    assert np.array_equal(guessed.trajectory.contacts, plain.trajectory.contacts)
    assert [w.message for w in guessed.warnings] == [w.message for w in plain.warnings]
    if robot.tree.loops:  # the IK projects onto the loops after iterating: never guessed
        assert guessed_ik.guessed == 0
    elif not plain.warnings:  # (dircon_biped cannot follow com_shift: few clean samples)
        assert guessed_ik.guessed > len(plain.trajectory.q) / 2
        assert guessed_ik.steps < 0.85 * plain_ik.steps
