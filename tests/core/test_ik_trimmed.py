"""The trimmed whole-body IK (cached support polygon, continuation from the last solve, steps
taken without a line search once the iterations settle, stopping when the remaining steps are
predicted below the tolerance) on fixed drag events, each solved from where the last one
ended, against references of its own:

- placo's own plain iteration of the same problem (the same tasks, posture, damping and CoM
  polygon; no Python of ours) run until |dq| < 1e-11: the configuration the iterations converge
  to. The IK must land within SAME_FIXED_POINT of it; where placo's loop crawls instead, the
  IK's foot must be at least as close to the target as placo's loop ever gets;
- pinocchio's frame placements and centre of mass at the answer, the target itself, the
  right sole's corners and the joint limits: the result's reached flag, CoM margin and joints
  near a limit are what they say.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from scipy.spatial import ConvexHull

from app.core.posing.ik import REACHED_M, REACHED_RAD, IkTargets, WholeBodyIK
from app.core.posing.ik_verdict import NEAR_LIMIT_RAD
from app.core.robot.loading import load_robot
from app.core.robot.model import RobotModel
from tests.conftest import ROBAN_URDF
from tests.core.foot_drags import placement, placo_fixed_point

SAME_FIXED_POINT = 5e-6
"""[rad, m] per configuration entry: the IK stops once the steps left are predicted below
1e-6 in norm; the plain iteration's own residue at 1e-11 is negligible."""
CONVERGED_WITHIN = 20
"""Plain iterations: events where placo's plain loop needs more are not compared with its end.
There it crawls (the CoM on the polygon's edge, a leg at a joint limit: the active constraint
leaves a weak direction along which each step moves little) or oscillates at a stretched leg,
and the IK stops before it does, where its goal cost stops falling: its foot is then no further
from the target than where placo's loop ends (Roban S14: 3 of the 40 events, and the first
event on both robots)..."""
NO_FURTHER_M = 1e-6
"""[m] ...within this: on the first event the two settle along different weak directions, the
IK's foot 0.3 µm further off on servo_biped."""
HELD_M = 1e-9
"""[m] The right foot (held hard, re-anchored exactly) stays where it stood."""


def _circle(robot, q, events=40):
    """Left-foot targets around a 3 cm circle, 2 cm up (the bench's drag)."""
    start = robot.link_placements(q, robot.model.createData())[robot.feet[0].link]
    for k in range(events):
        angle = 2.0 * np.pi * k / 20.0
        target = start.copy()
        target[:3, 3] += [0.03 * np.cos(angle), 0.03 * np.sin(angle), 0.02 + 0.01 * np.sin(angle)]
        yield target


def _miss(robot: RobotModel, q: np.ndarray, target: np.ndarray) -> tuple[float, float]:
    """(distance [m], turn [rad]) of the left foot at q from `target`, by pinocchio."""
    T = placement(robot, q, robot.foot("left").link)
    turn = pin.log3(target[:3, :3].T @ T.rotation)
    return float(np.linalg.norm(T.translation - target[:3, 3])), float(np.linalg.norm(turn))


def _com_margin(robot: RobotModel, q: np.ndarray) -> float:
    """Signed distance [m] of the CoM's ground projection inside the right sole's hull at q
    (pinocchio's CoM and placement, scipy's hull: n·x + d ≤ 0 inside)."""
    right = robot.foot("right")
    T = placement(robot, q, right.link).homogeneous
    corners = (T[:3, :3] @ right.sole_corners_m.T + T[:3, 3:4]).T[:, :2]
    com = pin.centerOfMass(robot.model, robot.model.createData(), q)[:2]
    planes = ConvexHull(corners).equations
    return float(-(planes[:, :2] @ com + planes[:, 2]).max())


def _near_limit(robot: RobotModel, q: np.ndarray) -> tuple[str, ...]:
    """The joints with limits within NEAR_LIMIT_RAD of one at q, in joint order."""
    return tuple(
        j.name
        for j in robot.joints
        if j.kind != "continuous"
        and min(q[j.idx_q] - j.lower, j.upper - q[j.idx_q]) < NEAR_LIMIT_RAD
    )


@pytest.mark.parametrize("name", ["servo_biped", "roban"])
def test_drag_events_land_on_placos_own_fixed_point(name):
    robot = load_robot(str(ROBAN_URDF) if name == "roban" else name)
    ik = WholeBodyIK(robot)
    right = robot.foot("right").link
    q = robot.q_neutral.copy()
    compared = 0
    for k, target in enumerate(_circle(robot, robot.q_neutral)):
        a = ik.solve(q, IkTargets(T_world_left=target, stance="right", posture_q=q))
        distance, turn = _miss(robot, a.q, target)
        assert a.reached == (distance < REACHED_M and turn < REACHED_RAD), k
        assert a.reached and a.warnings == (), k  # the circle is within the left leg's reach
        held = placement(robot, a.q, right).homogeneous - placement(robot, q, right).homogeneous
        assert np.abs(held).max() < HELD_M, k
        assert a.com_margin_m == pytest.approx(_com_margin(robot, a.q), abs=1e-9), k
        assert a.com_margin_m >= 0.0, k
        assert a.joints_near_limit == _near_limit(robot, a.q), k
        fixed, iterations = placo_fixed_point(robot, ik, q, target, q)
        # Event 0 lifts the foot 3.6 cm (beyond one step: the IK approaches through
        # intermediate targets, the plain loop does not), so the two may settle apart along
        # the posture's weak directions; from there on each event is a few mm.
        if k > 0 and iterations < CONVERGED_WITHIN:
            assert np.abs(a.q - fixed).max() < SAME_FIXED_POINT, k
            compared += 1
        else:
            assert distance <= _miss(robot, fixed, target)[0] + NO_FURTHER_M, k
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
