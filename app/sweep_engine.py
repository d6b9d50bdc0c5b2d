"""Run a sweep's points on Dask distributed: a local cluster by default, or a scheduler address.

    engine = SweepEngine(scheduler=None, n_workers=2)     # starts a LocalCluster
    run = engine.start(points)                            # submits every point
    for result in run.results():                          # as they finish (as_completed)
        ...
    run.cancel()                                          # from any thread: stops the sweep
    engine.close()

Local cluster: worker *processes* (a solve holds the GIL), one thread each, one per core;
BLAS/OpenMP pinned to one thread in each (the workers' environment), so n workers use n cores.
A remote scheduler's workers must have this package installed and should set
OMP_NUM_THREADS=1 themselves.

The local cluster is private to the studio that starts it: its scheduler, workers and nannies
speak only TLS with credentials made for this run (`Security.temporary()`, kept in memory,
never on disk), so another process on the machine cannot connect to it and run code in the
workers or in the studio (Dask runs pickled tasks); and it serves no HTTP (Dask starts an HTTP
server on every scheduler and worker even without a dashboard: it is given no routes, bound
to 127.0.0.1 on a free port, and stopped once the cluster is up). A `scheduler` address uses
the caller's Dask security settings (`distributed.comm.tls.*` in the Dask configuration, or
DASK_DISTRIBUTED__COMM__TLS__* variables): give the remote cluster TLS and mutual
certificates there.
Before Dask's client is made for an address, the address is probed on this thread with a
connection and a handshake time-out (app/scheduler_probe.py): Dask's own time-out covers only
the TCP connect, so a peer that accepted and stayed silent kept the client waiting forever.
The local workers end with the studio however it ends, `kill -9` and a
solve holding the GIL included: each runs `app.core.parent_watch` as a preload.

A task evaluates a few points in turn (`evaluate_points`, `plan_tasks`): the scheduler, the
client and each worker spend CPU per Dask task (messages over TLS, bookkeeping; a few ms
against a 14-knot point's ~57 ms), and on n workers over n cores that CPU is taken from the
solves (bench --sweep's scaling law). The last 2 × workers points go one per task, so the end
of a sweep, when fewer tasks than workers are left, is as fine-grained as before; a sweep of
fewer than `CHUNK_FROM_PER_WORKER` points per worker is all single points. The process's cache
of built NLPs survives between tasks, so a worker builds each structure once. A worker that
dies mid-task (killed, out of memory) loses only its running tasks: the scheduler hands them to
another worker (up to `distributed.scheduler.allowed-failures` deaths per task), and a task that
raised is retried `RETRIES` times. A task of several points that still fails is split, its
points resubmitted one per task, so a point that kills its worker every time takes no other
point down with it; a single point that still fails is reported as failed, not dropped.
"""

from __future__ import annotations

import contextlib
import logging
import os
import struct
import threading
import time
import uuid
from collections.abc import Iterator, Sequence
from concurrent.futures import CancelledError
from typing import Any

from app.core.errors import StudioError
from app.core.parent_watch import PARENT_ENV
from app.core.sweeps.evaluate import PointResult, evaluate_points, failed_point
from app.core.sweeps.sampling import SweepPoint
from app.scheduler_probe import CONNECT_TIMEOUT_S, SchedulerProbeError, probe_scheduler

log = logging.getLogger(__name__)

RETRIES = 2
"""Times a task that raised is run again."""
CHUNK_POINTS = 3
"""Points per task before the sweep's tail (`plan_tasks`): bench --sweep scaled best with 3,
against 2 and 4 (docs/sweeps.md, "A few points per Dask task")."""
CHUNK_FROM_PER_WORKER = 8
"""Points per worker from which a sweep's points are grouped into tasks (below: one each)."""
TAIL_PER_WORKER = 2
"""The sweep's last TAIL_PER_WORKER × workers points go one per task."""
SINGLE_THREAD_ENV = {
    name: "1"
    for name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS")
}


class SweepEngineError(StudioError):
    """The sweep cannot run: scheduler unreachable, cluster failed to start."""


def local_cores() -> int:
    """Cores this process may use."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


WORKER_PRELOAD = "app.core.parent_watch"
"""Run in every local worker process as it starts (its `dask_setup`): it ends with the studio
even when the studio is killed with SIGKILL mid-solve (Dask's own parent watch is a thread,
which a solve holding the GIL keeps waiting)."""
LOCAL_CLUSTER_CONFIG: dict[str, list[str] | bool] = {
    "distributed.scheduler.http.routes": [],
    "distributed.worker.http.routes": [],
    # Dask's statistical profiler samples each worker's stack every 10 ms and ships it to the
    # scheduler: CPU the solves share their cores with, for a dashboard nobody can open
    # (about 1 of 60 CPU-ms per 14-knot point here, ~2 %: bench --sweep's scaling law).
    "distributed.worker.profile.enabled": False,
}
"""Dask configuration of the local cluster (the nannies hand it to their workers): its HTTP
servers serve nothing, its workers do not profile themselves."""


def _private_local_cluster(local_cluster: Any, n_workers: int) -> Any:
    """A LocalCluster of `n_workers` single-thread processes on 127.0.0.1 that speaks only TLS
    with this run's credentials and serves no HTTP routes."""
    import dask
    from distributed.security import Security

    env = {
        **SINGLE_THREAD_ENV,
        PARENT_ENV: str(os.getpid()),  # the workers end with this process, however it ends
        "DASK_DISTRIBUTED__WORKER__HTTP__ROUTES": "[]",
        "DASK_DISTRIBUTED__SCHEDULER__HTTP__ROUTES": "[]",
    }
    with dask.config.set(LOCAL_CLUSTER_CONFIG):
        return local_cluster(
            n_workers=n_workers,
            threads_per_worker=1,
            processes=True,
            host="127.0.0.1",
            protocol="tls://",
            security=Security.temporary(),
            dashboard_address="127.0.0.1:0",
            worker_dashboard_address="127.0.0.1:0",
            env=env,
            preload=[WORKER_PRELOAD],
            silence_logs=logging.ERROR,
        )


async def _stop_http(server: Any) -> None:
    http = getattr(server, "http_server", None)
    if http is not None:
        http.stop()
        server.services.pop("dashboard", None)


def _stop_worker_http(dask_worker: Any) -> None:
    http = getattr(dask_worker, "http_server", None)
    if http is not None:
        http.stop()


def plan_tasks(
    points: Sequence[SweepPoint], workers: int, chunk_points: int = CHUNK_POINTS
) -> list[tuple[SweepPoint, ...]]:
    """The points grouped into Dask tasks, in submission order (the scheduler runs them in
    that order): runs of `chunk_points`, then the last `TAIL_PER_WORKER` × workers points one
    each; all one each when there are fewer than `CHUNK_FROM_PER_WORKER` points per worker."""
    workers = max(workers, 1)
    if chunk_points <= 1 or len(points) < CHUNK_FROM_PER_WORKER * workers:
        return [(point,) for point in points]
    head = len(points) - TAIL_PER_WORKER * workers
    chunks = [tuple(points[i : min(i + chunk_points, head)]) for i in range(0, head, chunk_points)]
    return chunks + [(point,) for point in points[head:]]


class SweepEngine:
    """A Dask client on a local cluster (owned, closed with the engine) or a remote scheduler."""

    def __init__(
        self,
        scheduler: str | None = None,
        n_workers: int | None = None,
        *,
        fallback_local: bool = False,
        security: Any = None,
    ) -> None:
        """`scheduler` "tcp://host:port" connects to a running cluster; None starts a local one
        of `n_workers` processes (default: one per core). An unreachable scheduler raises
        SweepEngineError unless `fallback_local`, which starts the local cluster instead (and
        says so in `notes`). `security` (a `distributed.security.Security`) for a scheduler
        address; None takes the Dask configuration's (`distributed.comm.tls.*`)."""
        from distributed import Client, LocalCluster

        self.notes: list[str] = []
        self._cluster: Any = None
        self.local_size: int | None = None
        """The workers a local cluster was started with (its nannies keep that many; the
        scheduler's count may lag behind a worker that is registering or restarting), None
        for a scheduler address."""
        if n_workers is not None and not 1 <= n_workers <= 256:
            raise SweepEngineError(f"workers = {n_workers}: give 1 to 256")
        if scheduler is not None:
            try:
                # time-outs on the connection and on the greeting, on this thread (Dask's
                # client would wait forever for a silent peer: app/scheduler_probe.py)
                probe_scheduler(scheduler, security)
                self.client = Client(scheduler, timeout=CONNECT_TIMEOUT_S, security=security)
                self.address = scheduler
                return
            except Exception as error:  # whatever the peer made Dask's client raise: one line
                reason = (
                    f"{type(error).__name__}: {str(error).splitlines()[0] if str(error) else ''}"
                )
                if isinstance(error, SchedulerProbeError):
                    reason = str(error)
                elif isinstance(error, (MemoryError, struct.error)):
                    reason = "it does not speak Dask's protocol (its first frame is not one)"
                elif isinstance(error, TypeError) and "ssl" in str(error).lower():
                    reason = (
                        "a tls:// scheduler needs TLS credentials: set distributed.comm.tls.* "
                        "in your Dask configuration"
                    )
                message = f"cannot reach the Dask scheduler at {scheduler} ({reason})"
                if not fallback_local:
                    raise SweepEngineError(
                        f"{message}; check the address, or allow the local fallback "
                        "(sweep --local-fallback)"
                    ) from None
                self.notes.append(f"{message}; running on a local cluster instead")
        n = n_workers or local_cores()
        try:
            self._cluster = _private_local_cluster(LocalCluster, n)
        except Exception as error:  # a cluster that cannot start: ports, memory, sandboxing
            raise SweepEngineError(f"the local Dask cluster did not start: {error}") from None
        self.client = Client(self._cluster, security=self._cluster.security)
        self.address = self._cluster.scheduler_address
        self.local_size = n
        self._stop_http_servers()

    def _stop_http_servers(self) -> None:
        """Close the HTTP servers Dask started on the scheduler and every worker (they serve
        no routes here; closed, nothing listens but the TLS ports)."""
        scheduler = self._cluster.scheduler
        self._cluster.sync(_stop_http, scheduler)
        self.client.run(_stop_worker_http)

    @property
    def n_workers(self) -> int:
        return len(self.client.scheduler_info(n_workers=-1)["workers"])

    def worker_pids(self) -> dict[str, int]:
        """Worker address → its process id (for tests and diagnostics)."""
        return self.client.run(os.getpid)

    def start(self, points: Sequence[SweepPoint], *, chunk_points: int = CHUNK_POINTS) -> SweepRun:
        """Submit every point (`chunk_points` a task before the tail: `plan_tasks`); iterate
        `results()` of the returned run for them."""
        workers = self.local_size or self.n_workers
        return SweepRun(self.client, plan_tasks(points, workers, chunk_points))

    def prepare(self, point: SweepPoint) -> dict[str, float]:
        """Have every worker build the NLP of `point`'s structure and solve its anchor gait now,
        so that a sweep started afterwards on that structure pays only solves; worker address →
        the seconds it spent (0.0 where it was warm)."""
        from app.core.sweeps.evaluate import prepare_point

        workers = list(self.client.scheduler_info(n_workers=-1)["workers"])
        futures = [  # a task on each worker (its task thread, where the points run)
            self.client.submit(
                prepare_point, point, workers=[address], allow_other_workers=False, pure=False
            )
            for address in workers
        ]
        return dict(zip(workers, self.client.gather(futures), strict=True))

    def solve(self, point: SweepPoint) -> Any:
        """The GaitResult of one point, solved on a worker (whose NLP may be warm)."""
        from app.core.sweeps.evaluate import solve_point

        return self.client.submit(solve_point, point, pure=False, retries=RETRIES).result()

    def close(self) -> None:
        with contextlib.suppress(Exception):  # closing a half-dead cluster must not raise
            self.client.close()
        if self._cluster is not None:
            with contextlib.suppress(Exception):
                self._cluster.close()

    def __enter__(self) -> SweepEngine:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()


class SweepRun:
    """The submitted points of one sweep: results as they finish, cancel from any thread."""

    def __init__(self, client: Any, tasks: Sequence[Sequence[SweepPoint]]) -> None:
        """`tasks`: the points, grouped into the Dask tasks that evaluate them (`plan_tasks`)."""
        from distributed import as_completed

        self.points = {p.index: p for task in tasks for p in task}
        self.started_s = time.perf_counter()
        self._client = client
        self._cancelled = threading.Event()
        self._lock = threading.Lock()  # a failed task's resubmission against cancel()
        self._run_id = uuid.uuid4().hex[:12]
        self._index: dict[str, tuple[int, ...]] = {}
        """Task key → the indices of the points it evaluates."""
        self._futures = self._submit([tuple(task) for task in tasks], priority=0)
        self._completed = as_completed(self._futures)

    def _submit(self, tasks: list[tuple[SweepPoint, ...]], priority: int) -> list[Any]:
        keys = [
            f"sweep-{self._run_id}-point-{task[0].index}"
            if len(task) == 1
            else f"sweep-{self._run_id}-points-{task[0].index}-{task[-1].index}"
            for task in tasks
        ]
        futures = self._client.map(
            evaluate_points, tasks, key=keys, retries=RETRIES, pure=False, priority=priority
        )
        self._index.update({k: tuple(p.index for p in t) for k, t in zip(keys, tasks, strict=True)})
        return futures

    def _split(self, indices: tuple[int, ...]) -> None:
        """Resubmit the points of a task that failed every retry one per task, ahead of the
        points not yet started, into the same iteration (unless cancelled)."""
        with self._lock:
            if self._cancelled.is_set():
                return
            futures = self._submit([(self.points[i],) for i in indices], priority=1)
            self._futures.extend(futures)
            self._completed.update(futures)

    @property
    def cancelled(self) -> bool:
        return self._cancelled.is_set()

    def cancel(self) -> None:
        """Stop the sweep: unfinished points are dropped (running solves are abandoned on their
        workers), and `results()` ends after at most the result it is delivering."""
        with self._lock:
            self._cancelled.set()
            self._completed.clear()  # ends the iteration in `results`
            with contextlib.suppress(Exception):
                self._client.cancel(self._futures)

    def results(self) -> Iterator[PointResult]:
        """Each point's result as soon as its task is done, in finishing order (a task's points
        one after the other); a point that failed every retry on its own comes back as a failed
        result. Ends when all are in or on cancel."""
        for future in self._completed:
            if self._cancelled.is_set():
                return
            indices = self._index[future.key]
            if future.status == "finished":
                try:
                    results = future.result()
                except CancelledError:  # cancel() ran between the status and the result
                    if self._cancelled.is_set():
                        return
                    continue
                for result in results:
                    yield result
                    if self._cancelled.is_set():
                        return
            elif future.status == "cancelled":
                continue
            elif len(indices) > 1:
                error = future.exception()
                log.warning(
                    "sweep task %s failed (%s: %s): its %d points are run one by one",
                    future.key, type(error).__name__, error, len(indices),
                )  # fmt: skip
                self._split(indices)
            else:
                error = future.exception()
                yield failed_point(self.points[indices[0]], f"{type(error).__name__}: {error}")
            future.release()
