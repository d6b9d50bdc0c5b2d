"""The torque feed-forward over every core: a pool of warm worker processes.

`FeedForwardPool` starts its processes once (spawn: fresh interpreters, no forked threads or
sockets) with BLAS and OpenMP pinned to one thread each, and keeps them for every later run.
`torque_feedforward(..., pool=pool)` hands it the trajectory's chunks (app.core.dynamics.wbc
CHUNK_SAMPLES contiguous samples, each solved cold at its first sample and warm along it);
each worker keeps the QPs it has built, by robot, parameters and solver, so a second run on
the same robot pays no set-up. A task is a contiguous run of chunks (`chunk_runs`: about
RUNS_PER_WORKER runs per worker), solved chunk by chunk exactly as `solve_chunk` solves them
in one process and sent back as one result of stacked arrays, so the torques equal a serial
run's. Since the reduced QP made a 10 s motion ~0.1 s of CPU, a task per chunk (ten 50 kB
round trips, ten progress pushes) cost the pool about as much as it saved; and a motion
shorter than MIN_POOL_SAMPLES is not worth splitting at all (`worth_a_pool`).
"""

from __future__ import annotations

import hashlib
import multiprocessing
import os
import pickle
import shutil
import tempfile
import time
from collections.abc import Callable
from multiprocessing.pool import Pool
from pathlib import Path

from app.core.dynamics.wbc import (
    ChunkInput,
    ChunkResult,
    WbcParams,
    make_qp,
    solve_chunk,
    stack_results,
)
from app.core.dynamics.wbc_qp import QpSolver, WholeBodyQp
from app.core.parent_watch import die_with_parent, on_spawner_thread
from app.core.robot.model import RobotModel
from app.core.single_thread import single_thread_environment

RUNS_PER_WORKER = 4
"""Tasks per worker in a run. Measured (2 workers, servo_biped squats, CPU time per worker):
one run each leaves a worker with the slow chunks (contact switches, solved by DAQP) and the
other idle (busiest worker 0.5–0.8 of the ideal share); four runs each balance to 0.98 while
the main process spends half the CPU of a task per chunk (29 vs 82 ms on 60 s of motion)."""
MIN_POOL_SAMPLES = 1000
"""Samples below which the studio and the CLI (--workers 0) solve in-process. Measured on the
shared 2-core machine: serial ≈ 0.09 ms of CPU per sample (servo_biped squats); two warm
workers took 70 ms on the 951-sample squats (90 ms serial), i.e. ≈ 25 ms on top of half the
work. The pool thus pays from ~500 samples with two free cores, from ~1100 when the machine
gives the pair 1.3× one core (typical here), never when it gives 1×; 1000 (10 s at 100 Hz)."""
MAX_CACHED_QPS = 4
"""QPs a worker keeps (robots × parameters × solver) before it forgets the oldest."""

_worker_qps: dict[tuple, tuple[RobotModel, WholeBodyQp]] = {}
"""In a worker process only: the QPs it has built, oldest first."""


class FeedForwardPool:
    """Warm worker processes for the torque feed-forward; use `with` or call `close`."""

    def __init__(self, workers: int | None = None) -> None:
        self.workers = max(1, workers or os.cpu_count() or 1)
        with single_thread_environment():  # the processes start here, inheriting it
            # started on a thread that lives as long as the studio: they end with it
            self._pool: Pool = on_spawner_thread(
                lambda: multiprocessing.get_context("spawn").Pool(
                    self.workers, initializer=die_with_parent
                )
            )
            self._pool.map(_warm_up, range(self.workers), chunksize=1)
        self._robot: tuple[RobotModel, str, str] | None = None
        self._folder = Path(tempfile.mkdtemp(prefix="feedforward-pool-"))
        """The robots handed to the workers, one file each: a task carries its path only."""

    def map_chunks(
        self,
        robot: RobotModel,
        params: WbcParams,
        solver: QpSolver,
        chunks: list[ChunkInput],
        progress: Callable[[float], None] | None,
    ) -> list[ChunkResult]:
        """Solve the chunks in the workers, results in chunk order."""
        key, path = self._pickled(robot)
        runs = chunk_runs(len(chunks), self.workers)
        tasks = [(key, path, params, solver, chunks[start:stop]) for start, stop in runs]
        results, done = [], 0
        for (start, stop), result in zip(
            runs, self._pool.imap(_solve_task, tasks, chunksize=1), strict=True
        ):
            results.append(result)
            done += stop - start
            if progress is not None:
                progress(done / len(chunks))
        return results

    def busy_wall_s(self, tasks: int, seconds: float) -> float:
        """Wall time of `tasks` busy loops of `seconds` CPU each over the pool: what the
        machine gives these processes right now (the bench's ceiling for the scaling)."""
        begin = time.perf_counter()
        self._pool.map(spin, [seconds] * tasks, chunksize=1)
        return time.perf_counter() - begin

    def _pickled(self, robot: RobotModel) -> tuple[str, str]:
        """The robot pickled once per robot object into the pool's folder: its digest (the
        workers' cache key) and the file's path. Tasks used to carry the pickle itself
        (0.26 MB for servo_biped, on every chunk); a worker now reads it once per robot."""
        if self._robot is None or self._robot[0] is not robot:
            blob = pickle.dumps(robot, protocol=pickle.HIGHEST_PROTOCOL)
            key = hashlib.sha1(blob).hexdigest()
            path = self._folder / f"{key}.pickle"
            if not path.exists():
                path.write_bytes(blob)
            self._robot = (robot, key, str(path))
        return self._robot[1], self._robot[2]

    def close(self) -> None:
        self._pool.terminate()
        self._pool.join()
        shutil.rmtree(self._folder, ignore_errors=True)

    def __enter__(self) -> FeedForwardPool:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def chunk_runs(n_chunks: int, workers: int) -> list[tuple[int, int]]:
    """(start, stop) of the contiguous runs of chunks the pool's tasks take, in order:
    RUNS_PER_WORKER per worker (fewer if there are fewer chunks), sizes differing by one."""
    runs = max(1, min(n_chunks, RUNS_PER_WORKER * workers))
    size, extra = divmod(n_chunks, runs)
    bounds, start = [], 0
    for k in range(runs if n_chunks else 0):
        stop = start + size + (k < extra)
        bounds.append((start, stop))
        start = stop
    return bounds


def worth_a_pool(n_samples: int, min_samples: int = MIN_POOL_SAMPLES) -> bool:
    """Whether a motion of n_samples is long enough for the pool to beat the serial run."""
    return n_samples >= min_samples


def spin(seconds: float) -> float:
    """Pure-Python busy work for about `seconds` of CPU: the pool's ceiling, for the bench."""
    end, count = time.process_time() + seconds, 0
    while time.process_time() < end:
        count += 1
    return float(count)


def _warm_up(_index: int) -> int:
    """Import the solver stack in the worker (the first real task then pays nothing)."""
    return os.getpid()


def _solve_task(task: tuple[str, str, WbcParams, QpSolver, list[ChunkInput]]) -> ChunkResult:
    """A run of chunks, each solved on its own as `solve_chunk` does, stacked into one result."""
    key, path, params, solver, chunks = task
    cache_key = (key, params, solver)
    if cache_key not in _worker_qps:
        robot = pickle.loads(Path(path).read_bytes())
        _worker_qps[cache_key] = (robot, make_qp(robot, params, solver))
        while len(_worker_qps) > MAX_CACHED_QPS:
            del _worker_qps[next(iter(_worker_qps))]
    _, qp = _worker_qps[cache_key]
    return stack_results([solve_chunk(qp, chunk, params) for chunk in chunks])
