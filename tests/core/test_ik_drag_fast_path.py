"""The drag IK's fast paths against oracles that do not share their shortcuts.

- the goal cost, read from placo's task errors, against the same weighted distances measured
  from pinocchio's forward kinematics at random configurations near and far from the goals;
- every answer of the bench's drag (the left foot around a 3 cm circle, 2 cm up, half of it out
  of Roban S14's reach) on servo_biped, Roban S14 and hybrid_leg_biped (loops): its foot and
  torso errors by pinocchio's FK of the answer, the reached verdict from those, the CoM margin
  in the stance sole's polygon recomputed by scipy's ConvexHull, the joints near a limit, the
  held foot where it was;
- the shortfall's null-space projector (from (JJᵀ)⁻¹, or an SVD where J is rank-deficient)
  against scipy's null_space basis, and its "held back by" lines against the same analysis
  written out here with that basis.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from scipy.linalg import null_space
from scipy.optimize import nnls
from scipy.spatial import ConvexHull

from app.bench.ik_baseline import drag_events
from app.core.posing.drag import Posing
from app.core.posing.ik import REACHED_M, REACHED_RAD, TORSO_TURN_RAD, TORSO_WEIGHT
from app.core.posing.ik_steps import HELD_MERIT_WEIGHT, ROTATION_WEIGHT
from app.core.posing.ik_verdict import NEAR_LIMIT_RAD
from app.core.posing.shortfall import AT_LIMIT_RAD, ON_EDGE_M, SHARE_NAMED, _free
from app.core.robot.loading import load_robot
from tests.conftest import ROBAN_URDF

EVENTS = 120
"""Drag events per robot: more than two turns of the bench's circle."""
SAME_M = 1e-12
"""[m, rad] An error measured here and the one the result reports: the same FK, rounding."""
POLYGON_M = 2e-6
"""[m] The CoM margin in the polygon recomputed at the answer and the result's, measured in
the polygon kept from the gesture's start (the held sole moves by solver residue only)."""


def _robot(name: str):
    return load_robot(str(ROBAN_URDF) if name == "roban" else name)


def _errors(T: np.ndarray, T_target: np.ndarray) -> tuple[float, float]:
    """(distance [m], turn [rad]) of placement T from T_target."""
    distance = float(np.linalg.norm(T[:3, 3] - T_target[:3, 3]))
    return distance, float(np.linalg.norm(pin.log3(T_target[:3, :3].T @ T[:3, :3])))


def _margin(points_xy: np.ndarray, p: np.ndarray) -> float:
    """Signed distance of p inside the convex hull of points (Qhull's facets: n·x + d ≤ 0)."""
    hull = ConvexHull(points_xy)
    return float(-(hull.equations[:, :2] @ p + hull.equations[:, 2]).max())


@pytest.mark.parametrize("name", ["servo_biped", "roban", "hybrid_leg_biped"])
def test_every_drag_answer_is_what_pinocchio_measures_of_it(name):
    robot = _robot(name)
    model, data = robot.model, robot.model.createData()
    q0 = robot.q_neutral.copy()
    left, right = robot.feet[0], robot.feet[1]
    start = robot.link_placements(q0, data)[left.link]
    events = drag_events(robot, q0, start, EVENTS)
    posing = Posing(robot)
    missed = 0
    for k, event in enumerate(events):
        result = posing.drag(event.q_before, "left", event.target)
        q = result.q
        pin.framesForwardKinematics(model, data, q)
        T_left = data.oMf[model.getFrameId(left.link)].homogeneous
        T_right = data.oMf[model.getFrameId(right.link)].homogeneous
        R_torso = data.oMf[model.getFrameId(robot.tree.root)].rotation
        distance, turn = _errors(T_left, event.target)
        torso = float(np.linalg.norm(pin.log3(event.R_world_torso.T @ R_torso)))
        assert result.position_error_m["left"] == pytest.approx(distance, abs=SAME_M)
        assert result.orientation_error_rad["left"] == pytest.approx(turn, abs=SAME_M)
        reached = distance < REACHED_M and turn < REACHED_RAD and torso < TORSO_TURN_RAD
        assert result.reached == reached, f"event {k}"
        missed += not reached
        assert bool(result.shortfall) == (not reached)
        # The right foot held where the event found it: FK of the pose the event started from.
        pin.framesForwardKinematics(model, data, event.q_from)
        T_held = data.oMf[model.getFrameId(right.link)].homogeneous.copy()
        assert np.abs(T_right - T_held).max() < 1e-9
        sole = (T_right[:3, :3] @ right.sole_corners_m.T + T_right[:3, 3:4]).T[:, :2]
        com = pin.centerOfMass(model, data, q)[:2]
        assert result.com_margin_m == pytest.approx(_margin(sole, com), abs=POLYGON_M)
        near = [
            joint.name
            for joint in robot.joints
            if joint.kind != "continuous"
            and min(q[joint.idx_q] - joint.lower, joint.upper - q[joint.idx_q]) < NEAR_LIMIT_RAD
        ]
        assert list(result.joints_near_limit) == near
        if robot.tree.loops:
            for loop in robot.tree.loops:
                gap = (
                    data.oMf[model.getFrameId(loop.link_a)].translation
                    - data.oMf[model.getFrameId(loop.link_b)].translation
                )
                assert np.abs(gap).max() < 1e-9
    if name == "roban":
        assert missed > EVENTS // 5  # the circle leaves its reach: the long path is covered


def test_the_goal_cost_is_the_weighted_distance_pinocchio_measures():
    """After a drag event sets the IK's goals (the moving foot, the torso hold, the held
    foot), the goal cost at random configurations around the answer — near the goals and
    further than a step, where the cost takes its other path — against the distances of the
    frames' placements by pinocchio."""
    robot = _robot("servo_biped")
    model, data = robot.model, robot.model.createData()
    q0 = robot.q_neutral.copy()
    start = robot.link_placements(q0, data)[robot.feet[0].link]
    events = drag_events(robot, q0, start, 8)
    posing = Posing(robot)
    for event in events:
        result = posing.drag(event.q_before, "left", event.target)
    ik = posing.ik
    held_target = result.placements["right"]
    rng = np.random.default_rng(3)
    for scale in (1e-4, 1e-2, 0.3):
        for _ in range(20):
            q = pin.integrate(model, result.q, scale * rng.normal(size=model.nv))
            ik._wrapper.state.q = q
            ik._wrapper.update_kinematics()
            cost = ik._goal_cost()
            pin.framesForwardKinematics(model, data, q)
            place = {
                link: data.oMf[model.getFrameId(link)].homogeneous
                for link in (robot.feet[0].link, robot.feet[1].link, robot.tree.root)
            }
            distance, turn = _errors(place[robot.feet[0].link], event.target)
            torso = np.linalg.norm(pin.log3(place[robot.tree.root][:3, :3].T @ event.R_world_torso))
            drift, drift_turn = _errors(place[robot.feet[1].link], held_target)
            expected = (
                distance**2
                + ROTATION_WEIGHT * turn**2
                + TORSO_WEIGHT * torso**2
                + HELD_MERIT_WEIGHT * (drift**2 + ROTATION_WEIGHT * drift_turn**2)
            )
            assert cost == pytest.approx(expected, rel=1e-9, abs=1e-15)


def test_the_projector_is_scipy_s_null_space_projector():
    """_free's X·P against X·N·Nᵀ with scipy's null_space basis N: full-rank Jacobians (one
    foot, both feet), a rank-deficient one (the SVD path) and none."""
    rng = np.random.default_rng(5)
    X = rng.normal(size=(4, 18))
    full = rng.normal(size=(6, 18))
    both = rng.normal(size=(12, 18))
    deficient = np.vstack([full, full[:4] + 1e-14 * rng.normal(size=(4, 18))])
    for J in (full, both, deficient):
        N = null_space(J, rcond=1e-10)
        assert np.abs(_free(J, X) - X @ N @ N.T).max() < 1e-8
    assert np.array_equal(_free(None, X), X)


def _held_back(robot, q: np.ndarray, target: np.ndarray, R_torso: np.ndarray, edges) -> list:
    """The shortfall's analysis (app.core.posing.shortfall's module docstring) written out
    with scipy's null_space basis: the lines it names."""
    model, data = robot.model, robot.model.createData()
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    foot, held, root = (
        model.getFrameId(link) for link in (robot.feet[0].link, robot.feet[1].link, robot.tree.root)
    )
    J = pin.getFrameJacobian(model, data, foot, pin.LOCAL_WORLD_ALIGNED)
    T = data.oMf[foot]
    turn = T.rotation @ pin.log3(T.rotation.T @ target[:3, :3])
    push = J[:3].T @ (target[:3, 3] - T.translation) + J[3:].T @ turn
    N = null_space(pin.getFrameJacobian(model, data, held, pin.LOCAL), rcond=1e-10)
    columns, labels = [], []
    for joint in robot.joints:
        if joint.kind == "continuous":
            continue
        for bound, sign, word in ((joint.upper, 1.0, "upper"), (joint.lower, -1.0, "lower")):
            if abs(q[joint.idx_q] - bound) < AT_LIMIT_RAD:
                column = np.zeros(model.nv)
                column[joint.idx_v] = sign
                columns.append(N.T @ column)
                labels.append(f"{joint.name} at its {word} limit ({np.rad2deg(bound):.1f}°)")
    J_com = pin.jacobianCenterOfMass(model, data, q)[:2]
    normals, offsets = edges
    for normal, offset in zip(normals, offsets, strict=True):
        if offset - normal @ data.com[0][:2] < ON_EDGE_M:
            columns.append(N.T @ (J_com.T @ normal))
            labels.append("the CoM kept over the support polygon")
    R = data.oMf[root].rotation
    J_root = pin.getFrameJacobian(model, data, root, pin.LOCAL_WORLD_ALIGNED)
    columns.append(N.T @ (-TORSO_WEIGHT * J_root[3:].T @ (R @ pin.log3(R.T @ R_torso))))
    labels.append("the torso kept as it was (drag the pelvis to lean it)")
    A, b = np.column_stack(columns), N.T @ push
    mu, _ = nnls(A, b)
    # A reason's share: μ_i·(a_i·b)/(b·b), its part of the push.
    shares: dict[str, float] = {}
    for label, share in zip(labels, mu * (A.T @ b) / float(b @ b), strict=True):
        shares[label] = shares.get(label, 0.0) + float(share)
    named = [label for label in shares if shares[label] >= SHARE_NAMED]
    return sorted(named, key=lambda label: -shares[label])


def test_held_back_lines_are_those_of_the_analysis_written_out():
    """Roban S14's drag events short of the target: the "held back by" lines of the result
    against the same analysis with scipy's basis (a share within 1e-6 of SHARE_NAMED could
    fall either side: none here)."""
    robot = _robot("roban")
    q0 = robot.q_neutral.copy()
    start = robot.link_placements(q0, robot.model.createData())[robot.feet[0].link]
    posing = Posing(robot)
    data = robot.model.createData()
    compared = 0
    for event in drag_events(robot, q0, start, 60):
        result = posing.drag(event.q_before, "left", event.target, explain=True)
        if result.reached:
            continue
        # The stance sole's polygon where the event started, shrunk by the IK's margin.
        pin.framesForwardKinematics(robot.model, data, event.q_from)
        T = data.oMf[robot.model.getFrameId(robot.feet[1].link)].homogeneous
        sole = (T[:3, :3] @ robot.feet[1].sole_corners_m.T + T[:3, 3:4]).T[:, :2]
        facets = ConvexHull(sole).equations
        edges = (facets[:, :2], -facets[:, 2] - posing.ik.com_margin_m)
        expected = _held_back(robot, result.q, event.target, event.R_world_torso, edges)
        said = [
            line.removeprefix("held back by ")
            for line in result.shortfall
            if line.startswith("held back by ")
        ]
        assert said == expected
        compared += 1
    assert compared > 10


def test_held_back_reasons_do_not_depend_on_the_units_of_their_constraints(monkeypatch):
    """A reason's share of the push is a fraction (the shares sum to at most 1): written in
    other units (every candidate's gradient × 10, as a limit in other units would be), the
    same reasons are named. Before, the shares were divided by the largest gradient's norm, so
    the 0.15 threshold named more or fewer reasons with the units."""
    import app.core.posing.shortfall as shortfall

    robot = _robot("roban")
    q0 = robot.q_neutral.copy()
    start = robot.link_placements(q0, robot.model.createData())[robot.feet[0].link]
    events = [e for e in drag_events(robot, q0, start, 60)]
    candidates = shortfall._candidates
    seen: list[dict[str, float]] = []
    reason_shares = shortfall.reason_shares

    def kept(*args):
        shares = reason_shares(*args)
        if isinstance(shares, dict):
            seen.append(shares)
        return shares

    def lines(factor: float) -> list[tuple[str, ...]]:
        def scaled(*args):
            labels, rows = candidates(*args)
            return labels, [factor * row for row in rows]

        monkeypatch.setattr(shortfall, "_candidates", scaled)
        posing = Posing(robot)
        return [
            tuple(posing.drag(e.q_before, "left", e.target, explain=True).shortfall) for e in events
        ]

    monkeypatch.setattr(shortfall, "reason_shares", kept)
    plain = lines(1.0)
    assert sum(any(line.startswith("held back by") for line in said) for said in plain) > 10
    assert seen and all(sum(s.values()) <= 1.0 + 1e-9 for s in seen)
    assert lines(10.0) == plain
