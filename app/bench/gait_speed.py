"""Bench entry of the gait planner's sweep point (issue 28).

- plan_sweep_point: the CPU time of one sweep point at steady state on the paper's case, timed
  where and as a sweep worker pays it: in a child process started with one BLAS/OpenMP thread
  (the sweep workers' environment, app/sweep_engine.py), the NLP built and the anchor solved
  once (ProblemCache, untimed, as `prepare_point` does ahead of the points), then each point
  (K0 changed, start = "anchor") through `evaluate_point`: the warm solve from the anchor, its
  readout and the point's metrics, the process's CPU time per point (median of K0_FACTORS);
  target ≤ 0.25 s. Baseline: the same NLP under IPOPT's defaults (gait_baseline.py) solving
  the same points from the same anchor in the same child (solve alone, no multipliers: what
  IPOPT's defaults can warm-start from); the same points solved cold from the built-in guess
  (a sweep with start = cold) are shown beside it.

  Why a child: timed in the bench's own process (as before), a point also paid OpenBLAS's
  spare threads spinning in MUMPS's dense kernels (process CPU 5–10 % above the thread's; the
  workers pin BLAS to one thread) and ran between the cold and baseline solves of the other
  points, so the figure read 0.47–0.62 s where a worker's point took 0.28–0.35 s.
"""

from __future__ import annotations

import dataclasses
import statistics
from typing import TYPE_CHECKING

from app.bench.registry import BenchContext, bench_entry
from app.bench.report import Figure
from app.bench.timing import PROCESS_CPU, in_single_thread_child, stopwatch

if TYPE_CHECKING:
    from app.core.sweeps.evaluate import ProblemCache
    from app.core.sweeps.sampling import SweepPoint

SWEEP_POINT_TARGET_S = 0.25
K0_FACTORS = (0.7, 0.8, 0.9, 1.1, 1.2, 1.3)
"""The sweep's points: K0 times these (one slider, as a 1-D sweep)."""


@bench_entry("plan_sweep_point")
def _entry_plan_sweep_point(ctx: BenchContext) -> tuple[dict, list[Figure]]:
    row = _bench_sweep_point()
    return row, [
        Figure.at_most(
            "gait sweep point at steady state, the paper's case, warm from the anchor, "
            "as a sweep worker runs it (CPU)",
            row["point_cpu_s"],
            "s",
            SWEEP_POINT_TARGET_S,
            row["defaults_point_cpu_s"],
            "the same NLP, IPOPT defaults, the same points from the same anchor (CPU, median)",
            f"median of {len(K0_FACTORS)} points (solve, readout and metrics, one BLAS thread, "
            f"derivatives {'compiled' if row['compiled'] else 'not compiled'}), "
            f"{row['iterations']} iterations vs {row['defaults_iterations']}; solved cold "
            f"from the built-in guess {row['cold_point_cpu_s']:.2f} s, "
            f"{row['cold_iterations']} iterations",
            met=row["converged"],
        )
    ]


def _bench_sweep_point() -> dict:
    """Run `_points_in_worker` in a child process with one BLAS thread (as a sweep worker)."""
    from app.bench.gait import compile_derivatives

    compile_derivatives()  # in the disk cache the worker loads them from
    return in_single_thread_child(_points_in_worker)


def _points_in_worker() -> dict:
    """The points as a sweep worker evaluates them (after its `prepare_point`), each timed in
    process CPU; then the same points cold, then under IPOPT's defaults."""
    from app.bench.gait_baseline import defaults_solver, ipopt_defaults
    from app.core.collocation.settings import GaitSettings
    from app.core.sweeps.evaluate import ProblemCache, prepare_point
    from app.core.sweeps.robot_variants import RobotVariant
    from app.core.sweeps.sampling import SweepPoint

    settings = GaitSettings()
    cache = ProblemCache()

    def point(index: int, factor: float, start: str) -> SweepPoint:
        changed = dataclasses.replace(settings, K0=factor * settings.K0)
        return SweepPoint(index, (changed.K0,), RobotVariant(), changed, start, settings)

    prepare_point(point(0, 1.0, "anchor"), cache)  # the NLP built, the anchor solved: untimed
    warm = [_timed_point(point(i, f, "anchor"), cache) for i, f in enumerate(K0_FACTORS)]
    cold = [_timed_point(point(i, f, "cold"), cache) for i, f in enumerate(K0_FACTORS)]
    problem, _ = cache.get((RobotVariant(), *settings.structure))
    anchor, _ = cache.anchor((RobotVariant(), *settings.structure), problem, settings)
    baseline = defaults_solver(problem)
    defaults = [
        ipopt_defaults(problem, p.settings, start_z=anchor.z, solver=baseline)
        for p in (point(i, f, "anchor") for i, f in enumerate(K0_FACTORS))
    ]
    return {
        "point_cpu_s": statistics.median(s for s, _, _ in warm),
        "cold_point_cpu_s": statistics.median(s for s, _, _ in cold),
        "iterations": int(statistics.median(i for _, i, _ in warm)),
        "cold_iterations": int(statistics.median(i for _, i, _ in cold)),
        "point_cpu_each_s": [s for s, _, _ in warm],
        "defaults_point_cpu_s": statistics.median(d["solve_cpu_s"] for d in defaults),
        "defaults_iterations": int(statistics.median(d["iterations"] for d in defaults)),
        "defaults_status": sorted({d["status"] for d in defaults}),
        "converged": anchor.converged and all(ok for *_, ok in warm + cold),
        "compiled": all(kind.loaded for kind in problem.nlp.kinds),
        "from_cache": problem.from_cache,
        "includes": "evaluate_point: warm solve from the anchor, readout, metrics; "
        "one BLAS thread; process CPU",
    }


def _timed_point(point: SweepPoint, cache: ProblemCache) -> tuple[float, int, bool]:
    """(process CPU [s], IPOPT iterations, solved) of one `evaluate_point`."""
    from app.core.sweeps.evaluate import evaluate_point

    with stopwatch(PROCESS_CPU) as lap:
        result = evaluate_point(point, cache)
    return lap.cpu_s, result.iterations, result.solved
