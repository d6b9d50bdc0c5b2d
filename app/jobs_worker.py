"""The solver worker process's side of app.jobs: what runs in "solver-worker".

Problems live and die here (casadi objects cannot be pickled): the first time the worker sees a
structure key it builds ``factory(structure_key)`` and caches it, then answers each job with
``problem.solve(settings, warm_start=<last result for that key>, iteration_callback=...)``. The
factory is a ``"module:function"`` string (imported here only, so the studio never imports the
planner) or a top-level function. The worker sends, in order, on its events pipe:

    ("progress", job_id, iteration, objective, constraint_violation)
    ("done", job_id, pickled result)      or      ("failed", job_id, message)

and ("prepared", None, key, error) for a build asked ahead of its first job. Whatever a job
raises is reported and the worker carries on; a result that cannot be pickled is a failure.
"""

from __future__ import annotations

import importlib
import pickle
import signal
import traceback
from collections.abc import Callable, Hashable
from multiprocessing.connection import Connection
from typing import Any, Protocol

from app.core.errors import StudioError
from app.core.parent_watch import die_with_parent

IterationCallback = Callable[[int, float, float], None]
"""Called by a solve at each iteration with (iteration, objective, constraint violation)."""


class SolvableProblem(Protocol):
    """What a factory builds, e.g. ``app.core.collocation.dircon.GaitProblem``."""

    def solve(
        self, settings: Any, warm_start: Any = None, iteration_callback: Any = None
    ) -> Any: ...


ProblemFactory = Callable[[Any], SolvableProblem]


def worker_main(factory: str | ProblemFactory, requests: Connection, events: Connection) -> None:
    """The worker process: build each structure once, solve every request, report back."""
    die_with_parent()  # killed with the studio, even mid-solve
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the studio's to handle
    build, broken = _resolve(factory)
    problems: dict[Hashable, SolvableProblem] = {}
    last_results: dict[Hashable, Any] = {}
    while True:
        try:
            request = pickle.loads(requests.recv_bytes())
        except EOFError:  # the studio is gone
            return
        if request is None:
            return
        job_id, settings, key = request
        if job_id is None:  # prepare: build only
            events.send(("prepared", None, key, _prepare(build, broken, problems, key)))
            continue
        if build is None:
            events.send(("failed", job_id, broken))
            continue
        report = _reporter(events, job_id)
        # A process boundary: whatever the job raises is reported, and the worker carries on.
        try:
            if key not in problems:
                problems[key] = build(key)
            result = problems[key].solve(
                settings, warm_start=last_results.get(key), iteration_callback=report
            )
            payload = pickle.dumps(result, protocol=pickle.HIGHEST_PROTOCOL)
        except Exception as error:
            events.send(("failed", job_id, _describe(error)))
            continue
        last_results[key] = result
        events.send(("done", job_id, payload))


def _prepare(
    build: ProblemFactory | None, broken: str, problems: dict[Hashable, Any], key: Hashable
) -> str:
    """Build `key`'s problem into the cache if it is not there; what went wrong, or ""."""
    if build is None:
        return broken
    if key in problems:
        return ""
    try:
        problems[key] = build(key)
    except Exception as error:
        return _describe(error)
    return ""


def _reporter(events: Connection, job_id: str) -> IterationCallback:
    def report(iteration: int, objective: float, constraint_violation: float) -> None:
        message = (int(iteration), float(objective), float(constraint_violation))
        events.send(("progress", job_id, *message))

    return report


def _resolve(factory: str | ProblemFactory) -> tuple[ProblemFactory | None, str]:
    if not isinstance(factory, str):
        return factory, ""
    module_name, _, name = factory.partition(":")
    try:
        return getattr(importlib.import_module(module_name), name), ""
    except Exception as error:  # reported on every job: the worker must not die at start
        return None, f"cannot load the problem factory {factory!r}: {_describe(error)}"


def _describe(error: Exception) -> str:
    if isinstance(error, StudioError):
        return str(error)
    traceback.print_exception(error)  # a bug rather than bad input: keep the trace on stderr
    return f"{type(error).__name__}: {error}"
