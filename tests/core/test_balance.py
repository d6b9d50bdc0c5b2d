"""The balance overlay's figures (Posing.balance, computed from one forward-kinematics pass)
against pinocchio on a fresh data, scipy's convex hull of the stance soles, and brute-force
point-to-segment distances."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from scipy.spatial import ConvexHull

from app.core.posing.drag import Posing
from app.core.robot.loading import load_robot
from tests.conftest import ROBAN_URDF


def _segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    t = np.clip(np.dot(p - a, b - a) / np.dot(b - a, b - a), 0.0, 1.0)
    return float(np.linalg.norm(p - (a + t * (b - a))))


def _independent(robot, q, stance):
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, q)
    sides = ("left", "right") if stance == "both" else (stance,)
    corners, contacts = [], []
    for foot in robot.feet:
        if foot.side not in sides:
            continue
        M = data.oMf[robot.model.getFrameId(foot.link, pin.BODY)]
        corners += [M.act(c)[:2] for c in foot.sole_corners_m]
        contacts.append(M.act(foot.sole_corners_m.mean(axis=0)))
    points = np.array(corners)
    hull = points[ConvexHull(points).vertices]
    com = pin.centerOfMass(robot.model, robot.model.createData(), q)
    return data, hull, np.array(com), contacts


@pytest.mark.parametrize("name", ["servo_biped", "roban"])
@pytest.mark.parametrize("stance", ["both", "left", "right"])
def test_balance_matches_pinocchio_and_a_convex_hull(name, stance):
    robot = load_robot(str(ROBAN_URDF) if name == "roban" else name)
    posing = Posing(robot)
    posing.stance = stance
    rng = np.random.default_rng(3)
    joint = robot.joints[int(rng.integers(len(robot.joints)))]
    q = robot.q_neutral.copy()
    q[joint.idx_q] = joint.lower + np.deg2rad(1.0)  # one joint 1° from its limit
    balance = posing.balance(q)
    data, hull, com, contacts = _independent(robot, q, stance)

    assert len(balance.polygon_xy) == len(hull)
    for corner in hull:
        assert np.min(np.linalg.norm(balance.polygon_xy - corner, axis=1)) < 1e-12
    assert np.allclose(balance.com_world, com, atol=1e-12)
    xy = com[:2]
    edges = [(hull[i], hull[(i + 1) % len(hull)]) for i in range(len(hull))]
    inside = ConvexHull(np.vstack([hull, xy])).volume <= ConvexHull(hull).volume * (1 + 1e-12)
    if inside:
        assert balance.com_margin_m == pytest.approx(
            min(_segment_distance(xy, a, b) for a, b in edges), abs=1e-12
        )
    else:
        assert balance.com_margin_m < 0.0
    assert joint.name in balance.joints_near_limit
    child = robot.tree.joints[joint.name].child
    where = data.oMf[robot.model.getFrameId(child, pin.BODY)].translation
    position = balance.joint_positions_near_limit[balance.joints_near_limit.index(joint.name)]
    assert np.allclose(position, where, atol=1e-12)
    assert len(balance.contact_frames) == len(contacts)
    for frame, centre in zip(balance.contact_frames, contacts, strict=True):
        assert np.allclose(frame[:3, 3], centre, atol=1e-12)
