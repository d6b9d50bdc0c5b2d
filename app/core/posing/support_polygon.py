"""The support polygon of the whole-body IK: the stance soles' convex hull, the CoM's margin
in it, and the CoM-in-polygon constraint of the QP (hard once the CoM is inside, a pull while
it is outside).

SupportPolygonMixin is one part of app.core.posing.ik.WholeBodyIK (it holds the placo solver
and the state declared below); convex_polygon is the hull alone.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import placo

from app.core.posing.ik_records import Stance
from app.core.robot.model import Foot, RobotModel

COM_PULL_WEIGHT = 1.0
"""While the CoM is outside the support polygon (a hard constraint would make the QP
infeasible), a CoM task this much heavier than the moving foot pulls it in; once inside, the
polygon is a hard constraint."""
OFF_POLYGON = np.array([[1e3, 1e3], [1e3, -1e3], [-1e3, -1e3], [-1e3, 1e3]])
"""Clockwise square [m] that no CoM leaves: the polygon constraint's "off" state."""
POLYGON_CACHE_M = 1e-6
"""Stance soles that moved less than this [m, and rotation-matrix entries] since the support
polygon was computed keep it: solver residue on a held foot (~1e-9 m) never misses the cache,
and the polygon is then at most about this far from the exact one."""
DEGENERATE_PAD_M = 5e-4
"""Half-size of the square put around each point of a sole without area (a foot whose
geometry is missing, or a line contact): its polygon is then a thin strip, not an error."""
ON_LINE = 1e-12
"""A point closer to the line through two corners than this fraction of the points' spread
lies on it (Qhull's round-off merging does the same): it is not a corner."""


def convex_polygon(points_xy: np.ndarray) -> np.ndarray:
    """Counter-clockwise corners of the convex hull of points (N, 2) [m], from the leftmost
    (the corners scipy's ConvexHull finds: tests/core/test_support_polygon_hull.py); points on
    a line (or one point) give the hull of small squares around them."""
    points_xy = np.asarray(points_xy, dtype=float)
    if not np.all(np.isfinite(points_xy)):
        raise ValueError("the support polygon's points are not all finite")
    corners = _hull_corners(points_xy)
    if len(corners) < 3:
        offsets = DEGENERATE_PAD_M * np.array([[1, 1], [1, -1], [-1, -1], [-1, 1]])
        points_xy = (points_xy[:, None, :] + offsets[None]).reshape(-1, 2)
        corners = _hull_corners(points_xy)
    return points_xy[corners]


def _hull_corners(points_xy: np.ndarray) -> list[int]:
    """Indices of the hull's corners, counter-clockwise (Andrew's monotone chain; a few dozen
    points here, so plain Python: scipy's Qhull costs its import, ~0.7 CPU-s per command)."""
    order = np.lexsort((points_xy[:, 1], points_xy[:, 0]))
    xy = points_xy.tolist()
    spread = float(np.ptp(points_xy, axis=0).max()) if len(xy) else 0.0
    tolerance = ON_LINE * spread * spread

    def chain(indices) -> list[int]:
        kept: list[int] = []
        for i in indices:
            while len(kept) >= 2:
                (ax, ay), (bx, by), (px, py) = xy[kept[-2]], xy[kept[-1]], xy[i]
                if (bx - ax) * (py - ay) - (by - ay) * (px - ax) > tolerance:
                    break
                kept.pop()
            kept.append(int(i))
        return kept

    lower, upper = chain(order), chain(order[::-1])
    return lower[:-1] + upper[:-1] if len(lower) + len(upper) > 4 else []


class SupportPolygonMixin:
    """The support polygon's part of WholeBodyIK (state set up by WholeBodyIK.__init__)."""

    robot: RobotModel
    _wrapper: placo.RobotWrapper
    _solver: placo.KinematicsSolver
    _data: pin.Data
    _placed_q: np.ndarray | None
    _foot_ids: dict[str, int]
    _stance_feet: dict[str, tuple[Foot, ...]]
    _polygon: placo.PolygonConstraint
    _polygon_on: bool
    _polygon_wanted: np.ndarray
    _polygon_pushed: np.ndarray | None
    _polygon_cache: tuple[str, list[np.ndarray], np.ndarray] | None
    _halfplanes: tuple[np.ndarray, np.ndarray, np.ndarray] | None
    _inside_at_start: bool | None
    _com_pull: placo.CoMTask | None

    def support_polygon(self, q: np.ndarray, stance: Stance) -> np.ndarray:
        """Counter-clockwise corners (xy) [m] of the convex hull of the stance soles at q.

        Cached per stance: while the stance soles stay within POLYGON_CACHE_M of where the
        polygon was computed (a drag of the other foot, solver residue along a motion), the
        same polygon is returned without a new hull."""
        pin.framesForwardKinematics(self.robot.model, self._data, q)
        self._placed_q = None
        return self._polygon_here(stance)

    def _polygon_here(
        self, stance: Stance, placements: dict[str, np.ndarray] | None = None
    ) -> np.ndarray:
        """support_polygon at the configuration self._data's frames were last placed at (or of
        the feet at `placements`, by side, when given)."""
        feet = self._stance_feet[stance]
        if placements is None:
            oMf, ids = self._data.oMf, self._foot_ids
            placements = {foot.side: oMf[ids[foot.side]].homogeneous for foot in feet}
        cache = self._polygon_cache
        if cache is not None and cache[0] == stance:
            for foot, T_then in zip(feet, cache[1], strict=True):
                if float(np.abs(placements[foot.side] - T_then).max()) >= POLYGON_CACHE_M:
                    break
            else:
                return cache[2]
        chosen = [placements[foot.side] for foot in feet]
        points = [
            (T[:3, :3] @ foot.sole_corners_m.T + T[:3, 3:4]).T[:, :2]
            for foot, T in zip(feet, chosen, strict=True)
        ]
        polygon = convex_polygon(np.concatenate(points))
        self._polygon_cache = (stance, chosen, polygon)
        return polygon

    def com_margin(self, q: np.ndarray, polygon: np.ndarray) -> float:
        """Signed distance [m] of the CoM's ground projection inside a convex polygon."""
        self._placed_q = None
        return self._margin_of(self.robot.com(q, self._data)[:2], polygon)

    def margin_at(self, com_xy: np.ndarray, polygon: np.ndarray) -> float:
        """Signed distance [m] of a ground point (a CoM's projection, already computed)
        inside a convex polygon."""
        return self._margin_of(np.asarray(com_xy, dtype=float)[:2], polygon)

    def _margin_of(self, com_xy: np.ndarray, polygon: np.ndarray) -> float:
        """Signed distance [m] of a point inside a convex polygon (its edges' inward normals
        kept for the last polygon asked about)."""
        normals, offsets = self._edges(polygon)
        return float((offsets - normals.dot(com_xy)).min())

    def _edges(self, polygon: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(outward unit normals, offsets) of a counter-clockwise polygon's edges: a point p
        is inside when normals·p ≤ offsets (cached for the last polygon asked about)."""
        if self._halfplanes is None or self._halfplanes[0] is not polygon:
            edges = np.roll(polygon, -1, axis=0) - polygon
            normals = (
                np.stack([edges[:, 1], -edges[:, 0]], axis=1)
                / np.linalg.norm(edges, axis=1)[:, None]
            )
            self._halfplanes = (polygon, normals, np.einsum("ij,ij->i", polygon, normals))
        return self._halfplanes[1], self._halfplanes[2]

    def _guard_com(self, polygon: np.ndarray) -> None:
        """Hard CoM-in-polygon constraint once the CoM is inside (the QP stays feasible from
        there, and it stays on for the rest of the solve: switching back and forth chatters);
        while the CoM is outside, a CoM task pulls it towards the polygon's centroid. The
        wrapper's kinematics are at the configuration asked about."""
        if self._polygon_on:
            return
        inside = self._inside_at_start
        self._inside_at_start = None
        if inside is None:
            inside = self._margin_of(np.asarray(self._wrapper.com_world())[:2], polygon) >= 0.0
        self._set_polygon(inside, polygon)
        if inside:
            self._set_com_pull(None)
        else:
            self._set_com_pull(polygon.mean(axis=0))

    def _set_com_pull(self, target_xy: np.ndarray | None) -> None:
        """Pull the CoM towards target_xy with COM_PULL_WEIGHT, or (None) not at all."""
        self._com_pull = self._ground_com_task(
            self._com_pull, target_xy, "com pull", COM_PULL_WEIGHT
        )

    def _ground_com_task(
        self, task: placo.CoMTask | None, target_xy: np.ndarray | None, name: str, weight: float
    ) -> placo.CoMTask | None:
        """A soft task pulling the CoM's ground projection to target_xy, added to the solver
        if it was not there; None (the task removed) when target_xy is None."""
        if target_xy is None:
            if task is not None:
                self._solver.remove_task(task)
            return None
        if task is None:
            task = self._solver.add_com_task(np.zeros(3))
            task.mask.set_axises("xy")
            task.configure(name, "soft", weight)
        task.target_world = np.array([*np.asarray(target_xy, dtype=float)[:2], 0.0])
        return task

    def _set_polygon(self, on: bool, polygon: np.ndarray | None = None) -> None:
        """Make the hard polygon constraint bite (the support polygon) or not (a huge square:
        placo has no cheap on/off for a hard constraint, and removing one is unsafe). Handed
        to placo by _push_polygon, right before a QP, and only when it changed: a solve turns
        it off at its start and on again at its first step, most often to the same polygon."""
        if on and polygon is not None:
            self._polygon_wanted = polygon
        elif not on:
            self._polygon_wanted = OFF_POLYGON
        self._polygon_on = on

    def _push_polygon(self) -> None:
        wanted = self._polygon_wanted
        if wanted is self._polygon_pushed:
            return
        corners = wanted if wanted is OFF_POLYGON else wanted[::-1]  # placo wants clockwise
        self._polygon.polygon = [np.array(p) for p in corners]
        self._polygon_pushed = wanted
