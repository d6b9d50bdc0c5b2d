"""The bench's one way of timing: a stopwatch (wall and CPU), calls timed one by one,
percentiles in milliseconds, and a child process with one BLAS thread to time a solve in.
Every entry times its work through these, so that what a figure measures (which clock, which
calls, which samples left out, which process) reads the same everywhere."""

from __future__ import annotations

import dataclasses
import multiprocessing
import time
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ProcessPoolExecutor
from contextlib import contextmanager
from typing import Any, TypeVar

import numpy as np

from app.core.single_thread import single_thread_environment

T = TypeVar("T")
R = TypeVar("R")

Clock = Callable[[], float]
WALL: Clock = time.perf_counter
THREAD_CPU: Clock = time.thread_time
"""CPU time of the calling thread: the work itself, not the other threads' (viser's)."""
PROCESS_CPU: Clock = time.process_time


@dataclasses.dataclass
class Lap:
    """What a `stopwatch` block took: wall time and CPU time [s] (NaN until it ends)."""

    wall_s: float = float("nan")
    cpu_s: float = float("nan")


@contextmanager
def stopwatch(cpu: Clock = THREAD_CPU) -> Iterator[Lap]:
    """Time the block: `with stopwatch() as lap: …` then `lap.wall_s`, `lap.cpu_s`."""
    lap = Lap()
    begin, begin_cpu = WALL(), cpu()
    try:
        yield lap
    finally:
        lap.wall_s, lap.cpu_s = WALL() - begin, cpu() - begin_cpu


def timed(function: Callable[[], object], runs: int, clock: Clock = WALL) -> list[float]:
    """Times [s] of `runs` calls of `function`, each timed alone."""
    return timed_each(lambda _: function(), range(runs), clock)


def timed_each(
    function: Callable[[T], object], items: Iterable[T], clock: Clock = WALL, pause_s: float = 0.0
) -> list[float]:
    """Times [s] of `function(item)` for each item, each call timed alone; `pause_s` of sleep
    after each call, untimed (events paced as a browser sends them)."""
    times = []
    for item in items:
        begin = clock()
        function(item)
        times.append(clock() - begin)
        if pause_s > 0.0:
            time.sleep(pause_s)
    return times


def percentiles_ms(
    seconds: Iterable[float] | np.ndarray, prefix: str = "", points: Iterable[int] = (50, 95)
) -> dict[str, float]:
    """{"<prefix>p50_ms": …, "<prefix>p95_ms": …} of times given in seconds."""
    ms = np.asarray(list(seconds) if not isinstance(seconds, np.ndarray) else seconds) * 1e3
    return {f"{prefix}p{p}_ms": float(np.percentile(ms, p)) for p in points}


def tallied(
    function: Callable[..., R], laps: list[float], clock: Clock = THREAD_CPU
) -> Callable[..., R]:
    """`function`, each call's time [s] appended to `laps` (to time a solver inside the work
    that calls it)."""

    def call(*args: Any, **kwargs: Any) -> R:
        begin = clock()
        try:
            return function(*args, **kwargs)
        finally:
            laps.append(clock() - begin)

    return call


def laps_each(
    function: Callable[[T], object], items: Iterable[T], cpu: Clock = THREAD_CPU
) -> list[Lap]:
    """Wall and CPU time of `function(item)` for each item, each call timed alone."""
    laps = []
    for item in items:
        with stopwatch(cpu) as lap:
            function(item)
        laps.append(lap)
    return laps


def in_single_thread_child(function: Callable[[], dict]) -> dict:
    """`function()` run in a child process started with one BLAS/OpenMP thread, as the
    studio's solver worker and the sweep workers run a solve (app/core/single_thread.py).
    Timed in the bench's own process, a solve also paid OpenBLAS's spare thread spinning in
    MUMPS's dense kernels: the paper's cold solve read 0.47-0.90 CPU-s from run to run."""
    context = multiprocessing.get_context("spawn")
    with single_thread_environment():
        pool = ProcessPoolExecutor(max_workers=1, mp_context=context)
    with pool:
        return pool.submit(function).result()
