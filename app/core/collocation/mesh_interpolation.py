"""Interpolation of a gait NLP's point from one mesh onto another (mesh refinement).

A fine mesh solved cold spends most of its time far from the answer (at 160 knots IPOPT
regularises the Hessian to ~1e13 and refactorises MUMPS again and again). The coarse optimum,
interpolated onto the fine grid, starts the fine solve near its own optimum (GaitProblem.solve
does this by itself above REFINE_ABOVE_KNOTS). The start is primal only: the coarse
multipliers scale with the mesh (a collocation row's multiplier ~ h), so IPOPT starts its
barrier afresh.

Per mode (each mode's nodes are evenly spaced in time, virtual knots included): node blocks
(q, v, a, u, λ) linearly in the mode's phase s ∈ [0, 1] at the nodes; interval blocks (γ, λ̄)
at the interval midpoints; the per-gait blocks (touch-down impulses, foothold slack or x1,
durations) are copied.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from app.core.collocation.nlp import SxNlp
from app.core.collocation.transcription import GaitLayout


class MeshedNlp(Protocol):
    """What interpolation needs of a GaitProblem."""

    nlp: SxNlp
    layout: GaitLayout
    baseline: bool


NODE_BLOCKS = ("q", "v", "a", "u", "lam")
INTERVAL_BLOCKS = ("gamma", "lam_mid")


def _phases(layout: GaitLayout, intervals: bool) -> list[np.ndarray]:
    """Per mode, the phase s ∈ [0, 1] of its nodes (or interval midpoints)."""
    phases = []
    for size in layout.sizes:
        if intervals:
            phases.append((np.arange(size - 1) + 0.5) / (size - 1))
        else:
            phases.append(np.linspace(0.0, 1.0, size))
    return phases


def interpolate_point(coarse: MeshedNlp, z: np.ndarray, fine: MeshedNlp) -> np.ndarray:
    """The coarse problem's point z moved onto the fine problem's variables, shape (nx_fine,)."""
    if coarse.baseline != fine.baseline:
        raise ValueError("mesh refinement needs the same problem (baseline or symmetric) on both")
    x = np.zeros(fine.nlp.nx)
    for name, fine_slices in fine.nlp.x_blocks.items():
        coarse_slices = coarse.nlp.x_blocks[name]
        values = np.array([z[s] for s in coarse_slices])  # (count, width)
        if name in NODE_BLOCKS or name in INTERVAL_BLOCKS:
            intervals = name in INTERVAL_BLOCKS
            source, target = _phases(coarse.layout, intervals), _phases(fine.layout, intervals)
            rows, first = [], 0
            for s_src, s_dst in zip(source, target, strict=True):
                block = values[first : first + len(s_src)]
                first += len(s_src)
                rows.append(np.column_stack([np.interp(s_dst, s_src, col) for col in block.T]))
            fine_values = np.vstack(rows)
        elif len(coarse_slices) == len(fine_slices):
            fine_values = values
        else:
            raise ValueError(f"cannot interpolate the NLP block {name!r}")
        for s, row in zip(fine_slices, fine_values, strict=True):
            x[s] = row
    return x
