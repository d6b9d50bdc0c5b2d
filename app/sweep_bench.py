"""`biped-studio bench --sweep`: gait points per second on 1 worker and on every local core.

Both runs solve the same points on a fresh LocalCluster, in the same bench run: first one point
per worker (each builds its NLP: the time to the first result, cluster start included), then the
timed points on warm workers. Scaling = (points/s on n workers) / (points/s on 1 worker), target
≥ 0.8 × n. The issue's 200-point estimate is 200 / (points/s on n workers).

CPU-time aware: the workers' process CPU seconds over the timed points are read before and after
(`Client.run(time.process_time)`), so `busy_cores` = CPU s / wall s says how many cores the
workers actually got; on a shared machine a scaling short of the target with busy_cores < n is
the other load, not the sweep (`cpu_scaling` is the scaling had each worker had its core). The
first result's time is split into the cluster start, the NLP
build with its anchor solve on the worker (`build_s`), and the point's own solve.
"""

from __future__ import annotations

import time

from app.core.sweeps.sampling import SweepPoint, sweep_points
from app.core.sweeps.spec import SweepSpec
from app.sweep_engine import SweepEngine, local_cores

SCALING_TARGET = 0.8
"""Scaling ≥ this × workers."""
FIRST_RESULT_TARGET_S = 5.0
SWEEP_200_TARGET_S = 120.0
BENCH_KNOTS = 14


def _spec(samples: int, seed: int) -> SweepSpec:
    return SweepSpec.from_mapping(
        {
            "sampling": "latin",
            "samples": samples,
            "seed": seed,
            "gait": {"knots": BENCH_KNOTS},
            "parameter": [
                {"name": "step_length_m", "min": 0.12, "max": 0.28},
                {"name": "H_s", "min": 0.65, "max": 0.85},
            ],
        }
    )


def _timed(n_workers: int, warmup: list[SweepPoint], points: list[SweepPoint]) -> dict:
    start = time.perf_counter()
    with SweepEngine(n_workers=n_workers) as engine:
        started = time.perf_counter() - start
        first = None
        first_result = None
        for result in engine.start(warmup[:n_workers]).results():
            if first is None:
                first, first_result = time.perf_counter() - start, result
        cpu0 = engine.client.run(time.process_time)
        t0 = time.perf_counter()
        results = list(engine.start(points).results())
        seconds = time.perf_counter() - t0
        cpu1 = engine.client.run(time.process_time)
    assert first_result is not None
    cpu = sum(cpu1[w] - cpu0[w] for w in cpu1 if w in cpu0)
    return {
        "workers": n_workers,
        "cluster_start_s": started,
        "first_result_s": first,
        "first_build_s": first_result.build_s,
        "first_solve_s": first_result.solve_s,
        "worker_cpu_s": cpu,
        "busy_cores": cpu / seconds,
        "cpu_s_per_point": cpu / max(len(results), 1),
        "points": len(results),
        "solved": sum(r.solved for r in results),
        "seconds": seconds,
        "points_per_s": len(results) / seconds,
    }


def bench_sweep(points: int = 40) -> dict:
    """Throughput on 1 and on all local cores, the scaling ratio and the first-result time."""
    cores = local_cores()
    warmup = sweep_points(_spec(cores, seed=100))
    timed = sweep_points(_spec(points, seed=101))
    one = _timed(1, warmup, timed)
    many = _timed(cores, warmup, timed)
    scaling = many["points_per_s"] / one["points_per_s"]
    # what the scaling would be if every worker had its core: n × (CPU s per point on 1 worker)
    # / (CPU s per point on n); below n only by the sweep's own overhead (scheduling, copies)
    cpu_scaling = cores * one["cpu_s_per_point"] / many["cpu_s_per_point"]
    return {
        "knots": BENCH_KNOTS,
        "cores": cores,
        "one_worker": one,
        "all_cores": many,
        "scaling": scaling,
        "cpu_scaling": cpu_scaling,
        "scaling_target": SCALING_TARGET * cores,
        "sweep_200_estimate_s": 200.0 / many["points_per_s"],
    }
