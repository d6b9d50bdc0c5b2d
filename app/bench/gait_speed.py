"""Bench entry of the gait planner's sweep point (issue 28).

- plan_sweep_point: the CPU time of one sweep point at steady state on the paper's case: the
  problem built and its anchor solved once (what a sweep worker keeps, app/core/sweeps), then
  points that change K0 each solved warm from the anchor, readout included (the median of
  POINTS); target ≤ 0.25 s. Baseline: the same points solved cold from the built-in guess (a
  sweep with start = cold), in the same run.
"""

from __future__ import annotations

import dataclasses
import statistics

from app.bench.registry import BenchContext, bench_entry
from app.bench.report import Figure
from app.bench.timing import PROCESS_CPU, stopwatch

SWEEP_POINT_TARGET_S = 0.25
K0_FACTORS = (0.7, 0.8, 0.9, 1.1, 1.2, 1.3)
"""The sweep's points: K0 times these (one slider, as a 1-D sweep)."""


@bench_entry("plan_sweep_point")
def _entry_plan_sweep_point(ctx: BenchContext) -> tuple[dict, list[Figure]]:
    row = _bench_sweep_point()
    return row, [
        Figure.at_most(
            "gait sweep point at steady state, the paper's case, warm from the anchor (CPU)",
            row["point_cpu_s"],
            "s",
            SWEEP_POINT_TARGET_S,
            row["cold_point_cpu_s"],
            "the same points solved cold from the built-in guess (CPU, median)",
            f"median of {len(K0_FACTORS)} points, {row['iterations']} iterations vs "
            f"{row['cold_iterations']}",
            met=row["converged"],
        )
    ]


def _bench_sweep_point() -> dict:
    from app.core.collocation.gait_problem import GaitProblem
    from app.core.collocation.settings import GaitSettings

    settings = GaitSettings()
    problem = GaitProblem()
    anchor = problem.solve(settings, cold=True)
    warm_s, cold_s, warm_it, cold_it, converged = [], [], [], [], anchor.converged
    for factor in K0_FACTORS:
        point = dataclasses.replace(settings, K0=factor * settings.K0)
        with stopwatch(PROCESS_CPU) as lap:
            warm = problem.solve(point, warm_start=anchor)
        warm_s.append(lap.cpu_s)
        warm_it.append(warm.iterations)
        with stopwatch(PROCESS_CPU) as lap:
            cold = problem.solve(point, cold=True)
        cold_s.append(lap.cpu_s)
        cold_it.append(cold.iterations)
        converged = converged and warm.converged and cold.converged
    return {
        "point_cpu_s": statistics.median(warm_s),
        "cold_point_cpu_s": statistics.median(cold_s),
        "iterations": int(statistics.median(warm_it)),
        "cold_iterations": int(statistics.median(cold_it)),
        "converged": converged,
    }
