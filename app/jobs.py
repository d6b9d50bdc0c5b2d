"""Worker processes for long solves: submit, progress, cancel, results.

A `SolverWorker` owns one long-lived process, "solver-worker", started with the *spawn* method (a
fresh interpreter: no forked copies of the studio's threads, locks or viser sockets), and one
parent thread, "solver-events", that turns the worker's messages into callbacks.

Protocol. casadi objects cannot be pickled, so problems live and die in the worker (what runs
there: app/jobs_worker.py): the first time it sees a structure key it builds
``factory(structure_key)`` and caches it, then answers each job with
``problem.solve(settings, warm_start=<last result for that key>, iteration_callback=...)``.
The factory is a ``"module:function"`` string (imported in the worker only, so the studio never
imports the planner) or a top-level function; the key must be hashable, picklable and hold all
that building needs. The worker sends, in order, on a pipe:

    ("progress", job_id, iteration, objective, constraint_violation)
    ("done", job_id, result)      or      ("failed", job_id, message)

Prepare. `prepare(structure_key)` asks an idle worker to build a structure ahead of the first
job that needs it (the studio does this when a robot loads, so the first *Solve* pays no
build); the worker answers ("prepared", None, key, error) and a job submitted meanwhile waits
for the build it needs anyway. A prepare never cancels a job and is skipped while one runs.

Every submitted job ends in exactly one of done / failed / cancelled, and no progress of a job is
delivered after its end. Any returned result, converged or not, is the next warm start of its
structure (the planner decides what to use of it); a solve that raised is not.

Pipes rather than a ``multiprocessing.Queue``: a pipe can be waited on together with the process
sentinel (crashes are seen at once, no polling); it pickles in the sending thread, so a result
that cannot be pickled is reported as failed (a Queue's feeder thread prints the error and the job
would hang); and the pipes of a terminated worker, possibly cut mid-message, are simply dropped.

Cancel. IPOPT cannot be interrupted politely: `cancel` terminates the process (SIGTERM, SIGKILL
after 0.5 s) and starts a fresh one, so **the cache of built problems and warm starts is lost**.
Cancelling while idle does nothing and keeps the cache. A `submit` while a job runs cancels that
job (reported "cancelled"; the studio shows its old result as stale) instead of queueing it: the
newest settings are the only ones the user still wants.

Crash. The reader thread waits on the worker's pipe *and* its process sentinel, so a worker that
dies (segfault, ``os._exit``, out of memory) is noticed at once: the running job is reported
failed with the exit code and a fresh worker is started. One that dies while idle is restarted
at the next submit, so a worker that cannot even start does not respawn in a loop.

Callbacks run on "solver-events", one at a time in event order, never under the worker's lock:
they may call `submit`, `cancel` and `status`. A callback that raises is logged and skipped.
"""

from __future__ import annotations

import contextlib
import logging
import multiprocessing
import pickle
import signal
import socket
import threading
from collections.abc import Callable, Hashable
from dataclasses import dataclass
from multiprocessing.connection import Connection, wait
from multiprocessing.process import BaseProcess
from typing import Any, Literal

from app.core.parent_watch import on_spawner_thread
from app.core.single_thread import single_thread_environment
from app.jobs_worker import IterationCallback, ProblemFactory, SolvableProblem, worker_main

__all__ = [
    "CLOSE_TIMEOUT_S",
    "STOP_TIMEOUT_S",
    "IterationCallback",
    "ProblemFactory",
    "SolvableProblem",
    "SolverStatus",
    "SolverWorker",
]

log = logging.getLogger(__name__)

STOP_TIMEOUT_S = 0.5
"""How long a terminated worker gets to exit before it is killed [s]."""
CLOSE_TIMEOUT_S = 2.0
"""How long `close` waits for an idle worker to exit, and for the reader thread [s]."""


@dataclass(frozen=True)
class SolverStatus:
    state: Literal["idle", "running", "closed"]
    job_id: str | None = None
    """The running job, when `state` is "running"."""


@dataclass
class _Process:
    """One worker process and the studio's ends of its two pipes."""

    process: BaseProcess
    requests: Connection
    events: Connection

    def stop(self) -> None:
        self.process.terminate()
        self.process.join(STOP_TIMEOUT_S)
        if self.process.is_alive():
            self.process.kill()
            self.process.join(STOP_TIMEOUT_S)

    def close(self) -> None:
        self.requests.close()
        self.events.close()
        if not self.process.is_alive():
            self.process.close()


class SolverWorker:
    """One solver process, its problem cache, and callbacks for its progress and results."""

    def __init__(self, factory: str | ProblemFactory, again: str = "press Solve again") -> None:
        """`again`: what the user does after a crash, said in the failure ("press Solve
        again"; a simulation's worker says its own button)."""
        if isinstance(factory, str) and ":" not in factory:
            raise ValueError(f"a problem factory is 'module:function', not {factory!r}")
        self._factory = factory
        self._again = again
        self._context = multiprocessing.get_context("spawn")
        self._lock = threading.Lock()
        """Guards the process, the running job, the notices and the callback lists."""
        self._callbacks: dict[str, list[Callable[..., None]]] = {
            kind: [] for kind in ("progress", "done", "failed", "cancelled", "prepared")
        }
        self._notices: list[tuple[Any, ...]] = []  # events made in the studio: cancellations
        self._retired: list[_Process] = []  # stopped processes whose pipes the reader closes
        self._running: str | None = None
        self._closed = False
        self._wake_r, self._wake_w = socket.socketpair()
        self._wake_w.setblocking(False)
        self._wake_r.setblocking(False)
        self._worker: _Process | None = self._spawn()
        self._reader = threading.Thread(target=self._read_events, name="solver-events", daemon=True)
        self._reader.start()

    # --- callbacks (registration returns the callback, so these work as decorators) ----------

    def on_progress(self, callback: Callable[[str, int, float, float], None]) -> Callable:
        """``callback(job_id, iteration, objective, constraint_violation)`` per iteration."""
        return self._register("progress", callback)

    def on_done(self, callback: Callable[[str, Any], None]) -> Callable:
        """``callback(job_id, result)`` when a solve returns (converged or not)."""
        return self._register("done", callback)

    def on_failed(self, callback: Callable[[str, str], None]) -> Callable:
        """``callback(job_id, message)`` when a solve raised or the process crashed."""
        return self._register("failed", callback)

    def on_cancelled(self, callback: Callable[[str], None]) -> Callable:
        """``callback(job_id)`` after `cancel`, a replacing `submit`, or `close` mid-solve."""
        return self._register("cancelled", callback)

    def on_prepared(self, callback: Callable[[Hashable, str], None]) -> Callable:
        """``callback(structure_key, error)`` when a `prepare` ends ("" when it was built)."""
        return self._register("prepared", callback)

    # --- commands ----------------------------------------------------------------------------

    def prepare(self, structure_key: Hashable) -> bool:
        """Build `structure_key`'s problem in the idle worker ahead of its first job; False
        (nothing sent) while a job runs or after close."""
        request = pickle.dumps((None, None, structure_key), protocol=pickle.HIGHEST_PROTOCOL)
        with self._lock:
            if self._closed or self._running is not None:
                return False
            if self._worker is None:
                self._worker = self._spawn()
            try:
                self._worker.requests.send_bytes(request)
            except OSError:  # died while idle: the next submit restarts it
                return False
        return True

    def submit(self, job_id: str, settings: Any, structure_key: Hashable) -> None:
        """Solve `settings` on the problem of `structure_key`; a running job is cancelled."""
        request = pickle.dumps((job_id, settings, structure_key), protocol=pickle.HIGHEST_PROTOCOL)
        with self._lock:
            if self._closed:
                raise RuntimeError("the solver worker is closed")
            if self._running is not None:
                self._notices.append(("cancelled", self._running))
                self._replace_locked()
            elif self._worker is None:
                self._worker = self._spawn()
            assert self._worker is not None
            try:
                self._worker.requests.send_bytes(request)
            except OSError:  # died while idle, not noticed yet: a fresh worker takes the job
                self._replace_locked()
                self._worker.requests.send_bytes(request)
            self._running = job_id
        self._wake()

    def cancel(self) -> bool:
        """Stop the running solve, losing the problem cache; False (cache kept) when idle."""
        with self._lock:
            job_id = self._running
            if job_id is None or self._closed:
                return False
            self._running = None
            self._notices.append(("cancelled", job_id))
            self._replace_locked()
        self._wake()
        return True

    @property
    def status(self) -> SolverStatus:
        with self._lock:
            if self._closed:
                return SolverStatus("closed")
            if self._running is None:
                return SolverStatus("idle")
            return SolverStatus("running", self._running)

    def close(self) -> None:
        """Cancel any running job, stop the process and the reader thread; idempotent."""
        with self._lock:
            if self._closed:
                return
            self._closed = True
            worker, self._worker = self._worker, None
            running, self._running = self._running, None
            if running is not None:
                self._notices.append(("cancelled", running))
        if worker is not None:
            if running is None:
                with contextlib.suppress(OSError):  # OSError: it is already gone
                    worker.requests.send_bytes(pickle.dumps(None))
                    worker.process.join(CLOSE_TIMEOUT_S)
            worker.stop()
        self._wake()
        if threading.current_thread() is not self._reader:
            self._reader.join(CLOSE_TIMEOUT_S)
            if self._reader.is_alive():
                log.warning("the solver-events thread is still in a callback after close()")
                return
        if worker is not None:
            worker.close()

    def __enter__(self) -> SolverWorker:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    # --- internals ---------------------------------------------------------------------------

    def _register(self, kind: str, callback: Callable) -> Callable:
        with self._lock:
            self._callbacks[kind].append(callback)
        return callback

    def _spawn(self) -> _Process:
        requests_r, requests_w = self._context.Pipe(duplex=False)
        events_r, events_w = self._context.Pipe(duplex=False)
        process = self._context.Process(
            target=worker_main,
            args=(self._factory, requests_r, events_w),
            name="solver-worker",
            daemon=True,
        )
        with single_thread_environment():  # one solve per core: BLAS threads only spin
            on_spawner_thread(process.start)  # it ends with the studio (app.core.parent_watch)
        requests_r.close()  # the worker's ends: once it dies, its pipe reads as end-of-file
        events_w.close()
        return _Process(process, requests_w, events_r)

    def _replace_locked(self) -> None:
        if self._worker is not None:
            self._worker.stop()
            self._retired.append(self._worker)
        self._worker = self._spawn()

    def _wake(self) -> None:
        # OSError: full (a wake-up is pending anyway) or closed (the reader is done)
        with contextlib.suppress(OSError):
            self._wake_w.send(b"\0")

    def _read_events(self) -> None:
        try:
            while True:
                with self._lock:
                    notices, self._notices = self._notices, []
                    retired, self._retired = self._retired, []
                    worker, closed = self._worker, self._closed
                for old in retired:
                    old.close()
                for notice in notices:
                    self._dispatch(*notice)
                if closed:
                    return
                waitables: list[Any] = [self._wake_r]
                if worker is not None:
                    waitables += [worker.events, worker.process.sentinel]
                ready = wait(waitables)
                if self._wake_r in ready:
                    self._drain_wake()
                if worker is not None and worker.events in ready:
                    self._receive(worker)
                elif worker is not None and worker.process.sentinel in ready:
                    self._on_exit(worker)
        finally:
            self._wake_r.close()
            self._wake_w.close()

    def _drain_wake(self) -> None:
        with contextlib.suppress(BlockingIOError):
            while self._wake_r.recv(4096):
                pass

    def _receive(self, worker: _Process) -> None:
        try:
            message = worker.events.recv()
        except (EOFError, OSError):  # the worker is exiting
            self._on_exit(worker)
            return
        self._handle(worker, message)

    def _handle(self, worker: _Process, message: tuple[Any, ...]) -> None:
        kind, job_id, *rest = message
        if kind == "prepared":
            if worker is self._worker:
                self._dispatch(kind, *rest)
            return
        with self._lock:
            current = worker is self._worker and job_id == self._running
            if current and kind != "progress":
                self._running = None
        if not current:
            return  # from a cancelled job or a stopped process
        if kind == "done":
            try:
                rest = [pickle.loads(rest[0])]
            except Exception as error:  # e.g. the result's class is not importable here
                kind, rest = "failed", [f"the solver's result could not be read: {error!r}"]
        self._dispatch(kind, job_id, *rest)

    def _on_exit(self, worker: _Process) -> None:
        while True:  # deliver what it sent before dying
            try:
                message = worker.events.recv() if worker.events.poll() else None
            except (EOFError, OSError):
                message = None
            if message is None:
                break
            self._handle(worker, message)
        worker.process.join(STOP_TIMEOUT_S)
        if worker.process.is_alive():
            worker.stop()
        code = worker.process.exitcode
        with self._lock:
            if worker is not self._worker:
                return  # stopped on purpose by cancel or close
            job_id, self._running = self._running, None
            self._worker = self._spawn() if job_id is not None else None
        worker.close()
        how = f"exit code {code}"
        if code is not None and -code in signal.valid_signals():
            how += f", {signal.Signals(-code).name}"
        if job_id is None:
            # SIGINT: Ctrl+C in the terminal reached the process group as the worker started
            # (before it could ignore it); the studio is stopping too: nothing to warn about
            level = logging.INFO if code == -signal.SIGINT else logging.WARNING
            log.log(
                level, "the solver process exited while idle (%s); it restarts on next solve", how
            )
            return
        message = f"the solver process crashed ({how}); it was restarted — {self._again}"
        self._dispatch("failed", job_id, message)

    def _dispatch(self, kind: str, *args: Any) -> None:
        with self._lock:
            callbacks = list(self._callbacks[kind])
        for callback in callbacks:
            try:
                callback(*args)
            except Exception:  # a studio bug must not stop the delivery of later events
                log.exception("a solver %r callback failed", kind)
