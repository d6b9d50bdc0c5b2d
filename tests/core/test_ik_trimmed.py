"""The trimmed whole-body IK (cached support polygon per stance, CoM from placo's own
kinematics, only the needed frame placements) gives the configurations of the solver as it was
before (tests/oracles/previous_ik.py, unchanged) on fixed drag sequences."""

from __future__ import annotations

import numpy as np
import pytest

from app.core.posing.ik import IkTargets, WholeBodyIK
from app.core.robot.loading import load_robot
from tests.conftest import ROBAN_URDF
from tests.oracles import previous_ik

SAME_Q = 1e-9


def _circle(robot, q, events=40):
    """Left-foot targets around a 3 cm circle, 2 cm up (the bench's drag)."""
    start = robot.link_placements(q, robot.model.createData())[robot.feet[0].link]
    for k in range(events):
        angle = 2.0 * np.pi * k / 20.0
        target = start.copy()
        target[:3, 3] += [0.03 * np.cos(angle), 0.03 * np.sin(angle), 0.02 + 0.01 * np.sin(angle)]
        yield target


@pytest.mark.parametrize("name", ["servo_biped", "roban"])
def test_a_drag_sequence_gives_the_previous_solvers_configurations(name):
    robot = load_robot(str(ROBAN_URDF) if name == "roban" else name)
    new, old = WholeBodyIK(robot), previous_ik.WholeBodyIK(robot)
    q_new = q_old = robot.q_neutral.copy()
    for target in _circle(robot, robot.q_neutral):
        a = new.solve(q_new, IkTargets(T_world_left=target, stance="right", posture_q=q_new))
        b = old.solve(
            q_old, previous_ik.IkTargets(T_world_left=target, stance="right", posture_q=q_old)
        )
        assert np.abs(a.q - b.q).max() < SAME_Q
        assert a.reached == b.reached and a.iterations == b.iterations
        assert a.warnings == b.warnings and a.joints_near_limit == b.joints_near_limit
        assert a.com_margin_m == pytest.approx(b.com_margin_m, abs=1e-9)
        q_new, q_old = a.q, b.q


def test_the_polygon_is_kept_while_the_stance_foot_moves_by_residue_and_redone_after():
    robot = load_robot("servo_biped")
    ik = WholeBodyIK(robot)
    q = robot.q_neutral.copy()
    polygon = ik.support_polygon(q, "right")
    nudged = q.copy()
    nudged[0] += 1e-8  # the whole robot, stance foot included, by solver residue
    assert ik.support_polygon(nudged, "right") is polygon
    moved = q.copy()
    moved[0] += 0.01
    shifted = ik.support_polygon(moved, "right")
    # Independently: the polygon of a robot translated by 1 cm is the polygon translated.
    assert np.allclose(
        np.sort(shifted, axis=0), np.sort(polygon + np.array([0.01, 0.0]), axis=0), atol=1e-12
    )
    assert ik.support_polygon(q, "both") is not shifted
