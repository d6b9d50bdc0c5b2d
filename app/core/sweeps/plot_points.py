"""Where each returned point of a sweep goes on its Pareto plot, and how it is drawn.

Solved points sit at their two metrics; a failed point has no metrics (or none to trust), so it
sits in a "failed" strip below the plot, the strip's points spread evenly over the x range in
index order (one apart from the other, to be told apart and clicked). Both the panel's plot and the clickable plot in the 3D
view draw these same positions.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from app.core.sweeps.evaluate import PointResult
from app.core.sweeps.outcomes import outcome_of
from app.core.sweeps.results import pareto_indices
from app.core.sweeps.spec import SweepSpec

KINDS = ("design", "front", "fell", "failed")
"""How a point is drawn: a solved design, on the Pareto front, fell in the simulation, failed."""
STRIP_GAP = 0.15
"""The failed strip's distance below the lowest solved point, × the y span."""


@dataclasses.dataclass(frozen=True)
class PlotPoints:
    """The returned points of a sweep placed on its plot."""

    labels: tuple[str, str]
    """The (x, y) metrics."""
    index: tuple[int, ...]
    """Point index of each row."""
    xy: np.ndarray
    """Plot position of each point, shape (n, 2), in the metrics' units."""
    kind: tuple[str, ...]
    """One of KINDS per point."""
    fell: np.ndarray
    """Whether each point fell in the simulation (bool (n,); a fallen point on the front is
    of kind "front")."""
    strip_y: float | None
    """The failed strip's y (None without a point in it)."""

    def kind_of(self, index: int) -> str | None:
        """How point `index` is drawn (None if it is not)."""
        return dict(zip(self.index, self.kind, strict=True)).get(index)


def plot_points(spec: SweepSpec, results: Sequence[PointResult]) -> PlotPoints:
    """Every returned point of the sweep placed on the plot of its two Pareto metrics."""
    metrics = (spec.pareto[0][0], spec.pareto[1][0])
    front = set(pareto_indices(spec, results))
    ordered = sorted(results, key=lambda r: r.index)
    xy = np.array([[r.metric(m) for m in metrics] for r in ordered], dtype=float).reshape(-1, 2)
    kinds = []
    for r in ordered:
        if outcome_of(r, spec.simulate).failed:
            kinds.append("failed")
        elif r.index in front:
            kinds.append("front")
        elif r.fell == 1.0:
            kinds.append("fell")
        else:
            kinds.append("design")
    in_strip = np.array([k == "failed" for k in kinds], dtype=bool)
    in_strip |= ~np.isfinite(xy).all(axis=1)
    placed = xy[~in_strip]
    strip_y = None
    if in_strip.any():
        xs = placed[:, 0] if len(placed) else np.array([0.0, 1.0])
        ys = placed[:, 1] if len(placed) else np.array([0.0, 1.0])
        x_lo, x_hi = float(xs.min()), float(xs.max())
        y_lo, y_hi = float(ys.min()), float(ys.max())
        y_span = y_hi - y_lo if y_hi > y_lo else max(abs(y_lo), 1.0)
        strip_y = y_lo - STRIP_GAP * y_span
        if x_hi <= x_lo:  # one solved x (or none): spread the strip around it
            pad = max(0.1 * abs(x_lo), 0.05)
            x_lo, x_hi = x_lo - pad, x_lo + pad
        rows = np.flatnonzero(in_strip)
        ends = (x_lo, x_hi) if len(rows) > 1 else (0.5 * (x_lo + x_hi),) * 2
        xy[rows, 0] = np.linspace(*ends, len(rows))
        xy[rows, 1] = strip_y
    fell = np.array([r.fell == 1.0 for r in ordered], dtype=bool)
    return PlotPoints(metrics, tuple(r.index for r in ordered), xy, tuple(kinds), fell, strip_y)
