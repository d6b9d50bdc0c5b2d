"""The trimmed whole-body IK (cached support polygon, continuation from the last solve, steps
taken without a line search once the iterations settle, stopping when the remaining steps are
predicted below the tolerance) against two references on fixed drag events, each solved from
the same start:

- placo's own plain iteration of the same problem (the same tasks, posture, damping and CoM
  polygon; no Python of ours) run until |dq| < 1e-11: the configuration the iterations converge
  to. The IK must land within SAME_FIXED_POINT of it (the previous solver's line search
  sometimes stopped up to 1e-4 short of it).
- the previous solver (tests/oracles/previous_ik.py, unchanged): the same reached flags,
  warnings and joints near a limit, the same configuration where the plain loop crawls.
"""

from __future__ import annotations

import numpy as np
import pytest

from app.core.posing.ik import IkTargets, WholeBodyIK
from app.core.robot.loading import load_robot
from tests.conftest import ROBAN_URDF
from tests.core.foot_drags import placo_fixed_point
from tests.oracles import previous_ik

SAME_FIXED_POINT = 5e-6
"""[rad, m] per configuration entry: the IK stops once the steps left are predicted below
1e-6 in norm; the plain iteration's own residue at 1e-11 is negligible."""
CONVERGED_WITHIN = 20
"""Plain iterations: events where placo's plain loop needs more are not compared. There it
crawls (the CoM on the polygon's edge, a leg at a joint limit: the active constraint leaves a
weak direction along which each step moves little) or oscillates at a stretched leg, and both
the IK and the previous solver stop before it does; from the same start they agree there."""


def _circle(robot, q, events=40):
    """Left-foot targets around a 3 cm circle, 2 cm up (the bench's drag)."""
    start = robot.link_placements(q, robot.model.createData())[robot.feet[0].link]
    for k in range(events):
        angle = 2.0 * np.pi * k / 20.0
        target = start.copy()
        target[:3, 3] += [0.03 * np.cos(angle), 0.03 * np.sin(angle), 0.02 + 0.01 * np.sin(angle)]
        yield target


@pytest.mark.parametrize("name", ["servo_biped", "roban"])
def test_drag_events_land_on_placos_own_fixed_point(name):
    robot = load_robot(str(ROBAN_URDF) if name == "roban" else name)
    new, old = WholeBodyIK(robot), previous_ik.WholeBodyIK(robot)
    q = robot.q_neutral.copy()
    compared = 0
    for k, target in enumerate(_circle(robot, robot.q_neutral)):
        a = new.solve(q, IkTargets(T_world_left=target, stance="right", posture_q=q))
        b = old.solve(q, previous_ik.IkTargets(T_world_left=target, stance="right", posture_q=q))
        assert a.reached == b.reached and a.warnings == b.warnings
        assert a.joints_near_limit == b.joints_near_limit
        assert a.com_margin_m == pytest.approx(b.com_margin_m, abs=1e-4)  # 0.1 mm
        fixed, iterations = placo_fixed_point(robot, new, q, target, q)
        # Event 0 lifts the foot 3.6 cm (beyond one step: the IK approaches through
        # intermediate targets, the plain loop does not), so the two may settle apart along
        # the posture's weak directions; from there on each event is a few mm.
        if k > 0 and iterations < CONVERGED_WITHIN:
            assert np.abs(a.q - fixed).max() < SAME_FIXED_POINT, k
            compared += 1
        else:
            assert np.abs(a.q - b.q).max() < 1e-4, k
        q = a.q
    assert compared >= 30  # the comparison covers the drag, not a few events


def test_a_solve_from_where_the_last_one_ended_equals_a_fresh_solve():
    """The continuation (placements, polygon, CoM side taken from the last solve) changes
    nothing: a solver that never saw the previous event gives the same configuration."""
    robot = load_robot("servo_biped")
    chained = WholeBodyIK(robot)
    q = robot.q_neutral.copy()
    for target in _circle(robot, robot.q_neutral, events=12):
        a = chained.solve(q, IkTargets(T_world_left=target, stance="right", posture_q=q))
        fresh = WholeBodyIK(robot)
        fresh.support_polygon(q, "right")  # the same support polygon cache state
        b = fresh.solve(q, IkTargets(T_world_left=target, stance="right", posture_q=q))
        assert np.abs(a.q - b.q).max() < 1e-12
        assert a.com_margin_m == pytest.approx(b.com_margin_m, abs=1e-12)
        q = a.q


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
