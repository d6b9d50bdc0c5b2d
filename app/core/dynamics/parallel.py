"""The torque feed-forward over every core: a pool of warm worker processes.

`FeedForwardPool` starts its processes once (spawn: fresh interpreters, no forked threads or
sockets) with BLAS and OpenMP pinned to one thread each, and keeps them for every later run.
`torque_feedforward(..., pool=pool)` hands it the trajectory's chunks (app.core.dynamics.wbc
CHUNK_SAMPLES contiguous samples, each solved cold at its first sample and warm along it);
each worker keeps the QPs it has built, by robot, parameters and solver, so a second run on
the same robot pays no set-up. The chunks come back in order and are solved exactly as
`solve_chunk` solves them in one process, so the torques are bit-identical to a serial run.
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

from app.core.dynamics.wbc import ChunkInput, ChunkResult, WbcParams, make_qp, solve_chunk
from app.core.dynamics.wbc_qp import QpSolver, WholeBodyQp
from app.core.robot.model import RobotModel
from app.core.single_thread import single_thread_environment

MAX_CACHED_QPS = 4
"""QPs a worker keeps (robots × parameters × solver) before it forgets the oldest."""

_worker_qps: dict[tuple, tuple[RobotModel, WholeBodyQp]] = {}
"""In a worker process only: the QPs it has built, oldest first."""


class FeedForwardPool:
    """Warm worker processes for the torque feed-forward; use `with` or call `close`."""

    def __init__(self, workers: int | None = None) -> None:
        self.workers = max(1, workers or os.cpu_count() or 1)
        with single_thread_environment():  # the processes start here, inheriting it
            self._pool: Pool = multiprocessing.get_context("spawn").Pool(self.workers)
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
        tasks = [(key, path, params, solver, chunk) for chunk in chunks]
        results = []
        for done, result in enumerate(self._pool.imap(_solve_task, tasks, chunksize=1)):
            results.append(result)
            if progress is not None:
                progress((done + 1) / len(chunks))
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


def spin(seconds: float) -> float:
    """Pure-Python busy work for about `seconds` of CPU: the pool's ceiling, for the bench."""
    end, count = time.process_time() + seconds, 0
    while time.process_time() < end:
        count += 1
    return float(count)


def _warm_up(_index: int) -> int:
    """Import the solver stack in the worker (the first real task then pays nothing)."""
    return os.getpid()


def _solve_task(task: tuple[str, str, WbcParams, QpSolver, ChunkInput]) -> ChunkResult:
    key, path, params, solver, chunk = task
    cache_key = (key, params, solver)
    if cache_key not in _worker_qps:
        robot = pickle.loads(Path(path).read_bytes())
        _worker_qps[cache_key] = (robot, make_qp(robot, params, solver))
        while len(_worker_qps) > MAX_CACHED_QPS:
            del _worker_qps[next(iter(_worker_qps))]
    _, qp = _worker_qps[cache_key]
    return solve_chunk(qp, chunk, params)
