"""Mesh refinement of the gait NLP: solve at a coarse mesh, interpolate, warm-start a finer one.

A fine mesh solved cold spends most of its time far from the answer (at 160 knots IPOPT
regularises the Hessian to ~1e13 and refactorises MUMPS again and again). The coarse optimum,
interpolated onto the fine grid, starts the fine solve near its own optimum.

Interpolation: app.core.collocation.mesh_interpolation. The start is primal only: the coarse
multipliers scale with the mesh (a collocation row's multiplier ~ h), so IPOPT starts its
barrier afresh.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from app.core.collocation.gait_problem import GaitProblem
from app.core.collocation.mesh_interpolation import interpolate_point
from app.core.collocation.result import GaitResult
from app.core.collocation.settings import GaitSettings


@dataclasses.dataclass(frozen=True)
class RefinedGait:
    """A fine-mesh gait solved from the interpolated coarse one."""

    coarse: GaitResult
    fine: GaitResult
    start_z: np.ndarray
    """The fine problem's starting point (the interpolated coarse optimum), shape (nx,)."""


def solve_refined(coarse: GaitProblem, fine: GaitProblem, settings: GaitSettings) -> RefinedGait:
    """Solve `settings` at the coarse problem's mesh, then at the fine one from its
    interpolation. `settings.knots` is the fine mesh's; the coarse solve uses the same
    settings with the coarse knots. If the coarse solve fails, the fine one starts cold."""
    coarse_result = coarse.solve(dataclasses.replace(settings, knots=coarse.structure[0]))
    if not coarse_result.converged:
        return RefinedGait(coarse_result, fine.solve(settings, cold=True), np.zeros(0))
    start = interpolate_point(coarse, coarse_result.z, fine)
    return RefinedGait(coarse_result, fine.solve(settings, start_z=start), start)
