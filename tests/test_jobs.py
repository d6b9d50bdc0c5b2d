"""The solver worker with real spawned processes: progress, results, cache, cancel, crash, close."""

from __future__ import annotations

import multiprocessing
import os
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest
from jobs_fixtures import CRASH_EXIT_CODE, SleepySettings, build_sleepy

from app.core.single_thread import SINGLE_THREAD_ENV
from app.jobs import SolverStatus, SolverWorker

FACTORY = "jobs_fixtures:build_sleepy"
TIMEOUT_S = 30.0
"""Generous: a spawned worker imports numpy, and CI machines are slow."""
ENDS = ("done", "failed", "cancelled")


class Recorder:
    """Every event the worker delivers, in order, with its arrival time."""

    def __init__(self, solver: SolverWorker) -> None:
        self.events: list[tuple[Any, ...]] = []
        self.times: list[float] = []
        self.threads: set[str] = set()
        self._changed = threading.Condition()
        for kind in (*ENDS, "progress"):
            getattr(solver, f"on_{kind}")(self._recorder(kind))

    def _recorder(self, kind: str) -> Callable[..., None]:
        def record(*args: Any) -> None:
            with self._changed:
                self.events.append((kind, *args))
                self.times.append(time.monotonic())
                self.threads.add(threading.current_thread().name)
                self._changed.notify_all()

        return record

    def wait_end(self, job_id: str) -> tuple[Any, ...]:
        """The event that ended `job_id` (done, failed or cancelled)."""
        with self._changed:
            ok = self._changed.wait_for(lambda: self._end(job_id) is not None, TIMEOUT_S)
            assert ok, f"{job_id} never ended; events: {self.events}"
            return self._end(job_id)  # type: ignore[return-value]

    def wait_progress(self, job_id: str, count: int = 1) -> None:
        with self._changed:
            assert self._changed.wait_for(
                lambda: len(self.of(job_id, "progress")) >= count, TIMEOUT_S
            )

    def of(self, job_id: str, *kinds: str) -> list[tuple[Any, ...]]:
        return [e for e in list(self.events) if e[1] == job_id and (not kinds or e[0] in kinds)]

    def _end(self, job_id: str) -> tuple[Any, ...] | None:
        ends = self.of(job_id, *ENDS)
        return ends[0] if ends else None


@pytest.fixture
def solver() -> Iterator[SolverWorker]:
    with SolverWorker(FACTORY) as worker:
        yield worker


def solve(
    solver: SolverWorker, recorder: Recorder, job_id: str, key: str = "walk", **settings: Any
):
    solver.submit(job_id, SleepySettings(**settings), key)
    return recorder.wait_end(job_id)


def test_progress_arrives_in_order_then_done_with_the_result(solver):
    recorder = Recorder(solver)
    kind, job_id, result = solve(solver, recorder, "job-1", steps=6, scale=2.0)
    assert (kind, job_id) == ("done", "job-1")
    np.testing.assert_array_equal(result.x, 2.0 * np.arange(6))
    progress = recorder.of("job-1", "progress")
    assert [p[2] for p in progress] == list(range(6))
    assert [p[3] for p in progress] == pytest.approx([1 / (i + 1) for i in range(6)])
    assert [p[4] for p in progress] == pytest.approx([10.0**-i for i in range(6)])
    assert recorder.events[-1][0] == "done"  # nothing after the end
    assert recorder.threads == {"solver-events"}
    assert solver.status == SolverStatus("idle")


def test_the_worker_runs_with_one_blas_thread_and_the_studio_keeps_its_own(solver):
    before = {name: os.environ.get(name) for name in SINGLE_THREAD_ENV}
    result = solve(solver, Recorder(solver), "env")[2]
    assert result.thread_env == dict.fromkeys(SINGLE_THREAD_ENV, "1")
    assert {name: os.environ.get(name) for name in SINGLE_THREAD_ENV} == before


def test_a_structure_is_built_once_and_warm_started_from_its_last_result(solver):
    recorder = Recorder(solver)
    first = solve(solver, recorder, "a", key="walk", scale=1.0)[2]
    second = solve(solver, recorder, "b", key="walk", scale=3.0)[2]
    other = solve(solver, recorder, "c", key="run", scale=5.0)[2]
    third = solve(solver, recorder, "d", key="walk", scale=7.0)[2]
    assert first.pid == second.pid == other.pid == third.pid
    assert (first.build, second.build, third.build) == (1, 1, 1)
    assert (first.solves, second.solves, third.solves) == (1, 2, 3)
    assert other.build == 2 and other.warm_start_x is None
    assert first.warm_start_x is None
    np.testing.assert_array_equal(second.warm_start_x, first.x)
    np.testing.assert_array_equal(third.warm_start_x, second.x)


def test_prepare_builds_ahead_and_the_first_solve_uses_that_build(solver):
    prepared: list[tuple[Any, str]] = []
    done = threading.Event()
    solver.on_prepared(lambda key, error: (prepared.append((key, error)), done.set()))
    assert solver.prepare("walk")
    assert done.wait(TIMEOUT_S)
    done.clear()
    assert solver.prepare("walk")  # already built: nothing to do, no second build
    assert done.wait(TIMEOUT_S)
    assert solver.prepare("unbuildable")
    recorder = Recorder(solver)
    first = solve(solver, recorder, "a", key="walk")[2]
    assert (first.build, first.solves, first.warm_start_x) == (1, 1, None)
    assert prepared[:2] == [("walk", ""), ("walk", "")]
    assert prepared[2][0] == "unbuildable" and "has no feet" in prepared[2][1]


def test_prepare_never_cancels_a_running_job(solver):
    recorder = Recorder(solver)
    solver.submit("long", SleepySettings(steps=50, step_s=0.02), "walk")
    recorder.wait_progress("long")
    assert not solver.prepare("run")
    assert recorder.wait_end("long")[0] == "done"


def test_cancel_stops_a_long_solve_and_the_cache_is_lost(solver):
    recorder = Recorder(solver)
    warm = solve(solver, recorder, "warm-up")[2]
    solver.submit("long", SleepySettings(steps=1000, step_s=0.05), "walk")
    recorder.wait_progress("long", 2)
    assert solver.status == SolverStatus("running", "long")
    started = time.monotonic()
    assert solver.cancel() is True
    end = recorder.wait_end("long")
    latency_s = recorder.times[recorder.events.index(end)] - started
    print(f"cancel latency: {latency_s * 1000:.1f} ms")
    assert end == ("cancelled", "long")
    assert solver.status == SolverStatus("idle")
    assert solver.cancel() is False

    after = solve(solver, recorder, "after")[2]
    # Events arrive in order on one thread: a progress of the cancelled job sent after its
    # end would have come before the next job's end.
    assert recorder.of("long")[-1] == end
    assert after.pid != warm.pid  # a fresh process …
    assert (after.build, after.solves, after.warm_start_x) == (1, 1, None)  # … with no cache


def test_cancel_while_idle_keeps_the_cache(solver):
    recorder = Recorder(solver)
    first = solve(solver, recorder, "a")[2]
    assert solver.cancel() is False
    second = solve(solver, recorder, "b")[2]
    assert (second.pid, second.build, second.solves) == (first.pid, 1, 2)
    assert [e[0] for e in recorder.events if e[0] != "progress"] == ["done", "done"]


def test_submit_while_running_cancels_the_old_job(solver):
    recorder = Recorder(solver)
    solver.submit("old", SleepySettings(steps=1000, step_s=0.05), "walk")
    recorder.wait_progress("old")
    solver.submit("new", SleepySettings(steps=3, scale=4.0), "walk")
    assert recorder.wait_end("new")[0] == "done"
    assert recorder.wait_end("old") == ("cancelled", "old")
    ends = [e[:2] for e in recorder.events if e[0] in ENDS]
    assert ends == [("cancelled", "old"), ("done", "new")]
    assert recorder.events.index(("cancelled", "old")) > max(
        recorder.events.index(e) for e in recorder.of("old", "progress")
    )


def test_a_crash_is_reported_with_its_exit_code_and_the_worker_restarts(solver):
    recorder = Recorder(solver)
    before = solve(solver, recorder, "before")[2]
    kind, job_id, message = solve(solver, recorder, "crash", steps=10, crash_at=2)
    assert (kind, job_id) == ("failed", "crash")
    assert message == (
        f"the solver process crashed (exit code {CRASH_EXIT_CODE}); it was restarted"
        " — press Solve again"
    )
    assert [p[2] for p in recorder.of("crash", "progress")] == [0, 1]
    assert solver.status == SolverStatus("idle")
    after = solve(solver, recorder, "after", scale=2.0)
    assert after[0] == "done"
    assert after[2].pid != before.pid and after[2].build == 1


def test_an_exception_fails_the_job_and_the_worker_keeps_its_cache(solver):
    recorder = Recorder(solver)
    first = solve(solver, recorder, "a")[2]
    assert solve(solver, recorder, "b", raise_at=1) == (
        "failed",
        "b",
        "ValueError: diverged at iteration 1",
    )
    third = solve(solver, recorder, "c")[2]
    assert (third.pid, third.build, third.solves) == (first.pid, 1, 3)
    np.testing.assert_array_equal(third.warm_start_x, first.x)  # the failure is no warm start


def test_unbuildable_structures_and_unpicklable_results_fail_with_a_message(solver):
    recorder = Recorder(solver)
    assert solve(solver, recorder, "a", key="unbuildable") == (
        "failed",
        "a",
        "the robot 'unbuildable' has no feet",  # a StudioError: its message, as is
    )
    kind, _, message = solve(solver, recorder, "b", unpicklable=True)
    assert kind == "failed" and "pickle" in message
    assert solve(solver, recorder, "c")[0] == "done"


def test_a_factory_that_cannot_be_imported_fails_every_job():
    with SolverWorker("jobs_fixtures:no_such_factory") as solver:
        recorder = Recorder(solver)
        for job_id in ("a", "b"):
            kind, _, message = solve(solver, recorder, job_id)
            assert kind == "failed"
            assert "cannot load the problem factory 'jobs_fixtures:no_such_factory'" in message
    with pytest.raises(ValueError, match="module:function"):
        SolverWorker("jobs_fixtures.build_sleepy")


def test_a_top_level_function_is_a_factory_too():
    with SolverWorker(build_sleepy) as solver:
        recorder = Recorder(solver)
        assert solve(solver, recorder, "a")[0] == "done"


@pytest.mark.expected_traceback("app.jobs")
def test_callbacks_may_call_the_worker_and_a_raising_one_is_skipped(solver):
    recorder = Recorder(solver)
    chained: list[str] = []

    @solver.on_done
    def next_job(job_id: str, result: Any) -> None:
        if len(chained) < 3:  # submit from the event thread: no lock is held here
            chained.append(job_id)
            solver.submit(f"{job_id}+", SleepySettings(steps=2), "walk")
        assert solver.status.state in ("idle", "running")

    @solver.on_progress
    def broken(*args: Any) -> None:
        raise RuntimeError("a bug in the studio")

    solver.submit("j", SleepySettings(steps=2), "walk")
    assert recorder.wait_end("j+++")[0] == "done"
    assert chained == ["j", "j+", "j++"]


def test_concurrent_submits_and_cancels_end_every_job_exactly_once(solver):
    recorder = Recorder(solver)
    job_ids = [f"t{thread}-{n}" for thread in range(4) for n in range(3)]

    def client(thread: int) -> None:
        for n in range(3):
            solver.submit(f"t{thread}-{n}", SleepySettings(steps=4, step_s=0.02), "walk")
            if n == 1:
                solver.cancel()

    threads = [threading.Thread(target=client, args=(t,)) for t in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    for job_id in job_ids:
        recorder.wait_end(job_id)
    for job_id in job_ids:
        assert len(recorder.of(job_id, *ENDS)) == 1, recorder.of(job_id)
        progress_after_end = recorder.of(job_id)[-1][0] == "progress"
        assert not progress_after_end
    assert sum(1 for e in recorder.events if e[0] == "done") >= 1  # the last submit is kept
    assert solver.status == SolverStatus("idle")


def test_close_cancels_the_running_job_and_leaves_no_child_process():
    solver = SolverWorker(FACTORY)
    recorder = Recorder(solver)
    solver.submit("long", SleepySettings(steps=1000, step_s=0.05), "walk")
    recorder.wait_progress("long")
    started = time.monotonic()
    solver.close()
    print(f"close while solving: {(time.monotonic() - started) * 1000:.1f} ms")
    assert recorder.of("long", *ENDS) == [("cancelled", "long")]
    assert solver.status == SolverStatus("closed")
    assert [p.name for p in multiprocessing.active_children()] == []
    assert not [t for t in threading.enumerate() if t.name == "solver-events"]
    solver.close()  # idempotent
    with pytest.raises(RuntimeError, match="closed"):
        solver.submit("late", SleepySettings(), "walk")

    with SolverWorker(FACTORY) as idle:
        Recorder(idle)
    assert multiprocessing.active_children() == []
