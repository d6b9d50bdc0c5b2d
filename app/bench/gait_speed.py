"""Bench entry of the gait planner's sweep point (issue 28).

- plan_sweep_point: the CPU time of one sweep point at steady state on the paper's case: the
  problem built and its anchor solved once (what a sweep worker keeps, app/core/sweeps), then
  points that change K0 each solved warm from the anchor, readout included (the median of
  POINTS); target ≤ 0.25 s. Baseline: the same NLP under IPOPT's defaults (gait_baseline.py)
  solving the same points from the same anchor (solve alone, no multipliers: what IPOPT's
  defaults can warm-start from); the same points solved cold from the built-in guess (a sweep
  with start = cold) are shown beside it.
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
            row["defaults_point_cpu_s"],
            "the same NLP, IPOPT defaults, the same points from the same anchor (CPU, median)",
            f"median of {len(K0_FACTORS)} points, {row['iterations']} iterations vs "
            f"{row['defaults_iterations']}; solved cold from the built-in guess "
            f"{row['cold_point_cpu_s']:.2f} s, {row['cold_iterations']} iterations",
            met=row["converged"],
        )
    ]


def _bench_sweep_point() -> dict:
    from app.bench.gait_baseline import defaults_solver, ipopt_defaults
    from app.core.collocation.gait_problem import GaitProblem
    from app.core.collocation.settings import GaitSettings

    settings = GaitSettings()
    problem = GaitProblem()
    anchor = problem.solve(settings, cold=True)
    baseline = defaults_solver(problem)
    warm_s, cold_s, warm_it, cold_it, converged = [], [], [], [], anchor.converged
    defaults = []
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
        defaults.append(ipopt_defaults(problem, point, start_z=anchor.z, solver=baseline))
        converged = converged and warm.converged and cold.converged
    return {
        "point_cpu_s": statistics.median(warm_s),
        "cold_point_cpu_s": statistics.median(cold_s),
        "iterations": int(statistics.median(warm_it)),
        "cold_iterations": int(statistics.median(cold_it)),
        "defaults_point_cpu_s": statistics.median(d["solve_cpu_s"] for d in defaults),
        "defaults_iterations": int(statistics.median(d["iterations"] for d in defaults)),
        "defaults_status": sorted({d["status"] for d in defaults}),
        "converged": converged,
    }
