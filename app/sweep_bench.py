"""`biped-studio bench --sweep`: gait points per second on 1 worker and on every local core.

Both runs solve the same points on a fresh LocalCluster, in the same bench run: first one point
per worker (each builds its NLP: the time to the first result, cluster start included), then the
timed points on warm workers. Scaling = (points/s on n workers) / (points/s on 1 worker), target
≥ 0.8 × n. The issue's 200-point estimate is 200 / (points/s on n workers).
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
        for _ in engine.start(warmup[:n_workers]).results():
            first = first if first is not None else time.perf_counter() - start
        t0 = time.perf_counter()
        results = list(engine.start(points).results())
        seconds = time.perf_counter() - t0
    return {
        "workers": n_workers,
        "cluster_start_s": started,
        "first_result_s": first,
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
    return {
        "knots": BENCH_KNOTS,
        "cores": cores,
        "one_worker": one,
        "all_cores": many,
        "scaling": scaling,
        "scaling_target": SCALING_TARGET * cores,
        "sweep_200_estimate_s": 200.0 / many["points_per_s"],
    }
