"""The support polygon's hull against scipy's ConvexHull (Qhull, the oracle here): the same
corners in the same counter-clockwise order, on random points and on two feet's soles."""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull

from app.core.posing.support_polygon import convex_polygon


def _same_cycle(ours: np.ndarray, reference: np.ndarray) -> bool:
    """The same corners in the same cyclic order (each may start anywhere)."""
    if ours.shape != reference.shape:
        return False
    start = np.flatnonzero((reference == ours[0]).all(axis=1))
    return len(start) == 1 and np.array_equal(np.roll(reference, -start[0], axis=0), ours)


def _qhull(points: np.ndarray) -> np.ndarray:
    return points[ConvexHull(points).vertices]


def test_random_points_give_qhull_s_corners():
    rng = np.random.default_rng(7)
    for n in (3, 4, 8, 16, 40):
        for _ in range(40):
            points = rng.normal(scale=0.1, size=(n, 2))
            assert _same_cycle(convex_polygon(points), _qhull(points))


def test_two_soles_side_by_side_and_staggered():
    """Eight sole corners; side by side the inner front and back corners lie on the hull's
    edges and are no corners (as Qhull says)."""

    def sole(x: float, y: float, yaw: float) -> np.ndarray:
        corners = np.array([[0.09, 0.04], [0.09, -0.04], [-0.07, -0.04], [-0.07, 0.04]])
        c, s = np.cos(yaw), np.sin(yaw)
        return corners @ np.array([[c, s], [-s, c]]) + (x, y)

    for left, right in [
        ((0.0, 0.06, 0.0), (0.0, -0.06, 0.0)),
        ((0.05, 0.06, 0.0), (-0.02, -0.06, 0.0)),
        ((0.03, 0.07, 0.2), (0.0, -0.05, -0.1)),
    ]:
        points = np.vstack([sole(*left), sole(*right)])
        ours = convex_polygon(points)
        assert _same_cycle(ours, _qhull(points))
    assert len(convex_polygon(np.vstack([sole(0, 0.06, 0), sole(0, -0.06, 0)]))) == 4
