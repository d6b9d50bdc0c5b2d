"""Fixed x and y ranges for uPlot charts whose series leave gaps as NaN.

viser hands a chart's columns to uPlot as float64 arrays, so a gap can only be NaN, never the
null uPlot skips: uPlot's automatic range over a column holding NaN is NaN, and the chart then
draws no axis and no point at all (a scatter whose series each hold some of the points, a curve
beside points at other x). With the y range given, uPlot never scans the data for it, and a NaN
point is simply not drawn. The x range is given too: a chart whose data is replaced in place
kept the x range of its first data (0-1 when that was a chart being rebuilt), not the new one's.
"""

from __future__ import annotations

import numpy as np
import viser.uplot as uplot

PAD_FRACTION = 0.08
"""Space left above and below the data, as a fraction of its span."""


def padded_range(*columns: np.ndarray) -> tuple[float, float]:
    """(low, high) around the finite values of `columns`, padded; (0, 1) when none is."""
    values = np.concatenate([np.asarray(c, dtype=float).ravel() for c in columns])
    finite = values[np.isfinite(values)]
    if not len(finite):
        return 0.0, 1.0
    low, high = float(finite.min()), float(finite.max())
    span = high - low
    pad = PAD_FRACTION * span if span > 0.0 else max(0.1 * abs(low), 1e-3)
    return low - pad, high + pad


def scales_for(x: np.ndarray, *columns: np.ndarray) -> dict[str, uplot.Scale]:
    """The scales of an x-y chart whose y `columns` may hold NaN gaps: x linear (not time),
    both fixed around their data (`padded_range`)."""
    return {
        "x": uplot.Scale(time=False, range=padded_range(x)),
        "y": uplot.Scale(range=padded_range(*columns)),
    }
