"""Problem factories for tests/test_jobs.py, top level so that the spawned solver worker imports them.

`SleepyProblem` stands in for the gait planner: its solve sleeps in small steps, reports each
step as an iteration, and returns a numpy result that says which build of the worker process
made the problem and what it was warm-started from.
"""

from __future__ import annotations

import itertools
import os
import threading
import time
from collections.abc import Callable, Hashable
from dataclasses import dataclass, field

import numpy as np

from app.core.errors import StudioError
from app.core.single_thread import SINGLE_THREAD_ENV

CRASH_EXIT_CODE = 3

_builds = itertools.count(1)
"""Problems built so far in this process (each worker process starts again from 1)."""


@dataclass(frozen=True)
class SleepySettings:
    steps: int = 5
    step_s: float = 0.01
    """Sleep per iteration [s]."""
    scale: float = 1.0
    crash_at: int | None = None
    """Iteration at which the process dies with os._exit(CRASH_EXIT_CODE)."""
    raise_at: int | None = None
    """Iteration at which solve raises ValueError."""
    unpicklable: bool = False
    """Return a result holding a lock, which pickle refuses."""


@dataclass(frozen=True)
class SleepyResult:
    x: np.ndarray
    """scale · [0, 1, …, steps − 1], shape (steps,)."""
    structure: Hashable
    build: int
    """Which build of its worker process made the problem (1 = the first)."""
    solves: int
    """Solves of this problem so far, this one included."""
    warm_start_x: np.ndarray | None
    """`x` of the result it was warm-started from, None on a cold start."""
    pid: int
    """The worker process."""
    thread_env: dict[str, str | None]
    """The worker's BLAS/OpenMP thread-count variables."""
    extra: object = field(default=None, compare=False)


class SleepyProblem:
    def __init__(self, structure: Hashable) -> None:
        self.structure = structure
        self.build = next(_builds)
        self.solves = 0

    def solve(
        self,
        settings: SleepySettings,
        warm_start: SleepyResult | None = None,
        iteration_callback: Callable[[int, float, float], None] | None = None,
    ) -> SleepyResult:
        self.solves += 1
        for iteration in range(settings.steps):
            if settings.crash_at == iteration:
                os._exit(CRASH_EXIT_CODE)
            if settings.raise_at == iteration:
                raise ValueError(f"diverged at iteration {iteration}")
            time.sleep(settings.step_s)
            if iteration_callback is not None:
                iteration_callback(iteration, 1.0 / (iteration + 1), 10.0**-iteration)
        return SleepyResult(
            x=settings.scale * np.arange(settings.steps, dtype=float),
            structure=self.structure,
            build=self.build,
            solves=self.solves,
            warm_start_x=None if warm_start is None else warm_start.x,
            pid=os.getpid(),
            thread_env={name: os.environ.get(name) for name in SINGLE_THREAD_ENV},
            extra=threading.Lock() if settings.unpicklable else None,
        )


def build_sleepy(structure: Hashable) -> SleepyProblem:
    """The factory: structure "unbuildable" fails the way a bad robot would."""
    if structure == "unbuildable":
        raise StudioError("the robot 'unbuildable' has no feet")
    return SleepyProblem(structure)
