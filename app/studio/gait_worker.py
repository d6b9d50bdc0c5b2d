"""The gait session's solver worker: the process (app.jobs) that builds and solves the gait
NLPs, started on first need, its events routed to the session, and the loaded robot's default
problem built ahead of the first solve (what `serve` asks). No viser."""

from __future__ import annotations

import logging
from collections.abc import Callable

from app.core.collocation.job_key import GaitProblemKey
from app.core.collocation.settings import GaitSettings
from app.gait_jobs import build_gait_problem
from app.jobs import SolverWorker
from app.studio.signals import Signal

log = logging.getLogger(__name__)

Progress = Callable[[str, int, float, float], None]
"""(job id, iteration, objective, constraint violation) of a solve under way."""
End = Callable[..., None]
"""end(job_id, error="", result=None, forget=False): a solve's answer; `forget`: the worker
restarted (its structures are gone)."""


class GaitWorker:
    """One solver worker for the gait session's solves (see the module's docstring)."""

    def __init__(self, on_progress: Progress, on_end: End, prepare_ahead: bool = False) -> None:
        self._on_progress, self._on_end = on_progress, on_end
        self.prepare_ahead = prepare_ahead
        """Build each robot's default problem in the worker when the robot loads."""
        self._worker: SolverWorker | None = None
        self.prepared: Signal[object] = Signal("gait_prepared")
        """Emitted with the structure key when the worker has built a problem ahead of time."""

    def submit(self, job_id: str, settings: GaitSettings, key: GaitProblemKey) -> None:
        """Solve `settings` on the structure `key` (built there once) as job `job_id`."""
        self._started().submit(job_id, settings, key)

    def prepare(self, key: GaitProblemKey) -> bool:
        """Build `key`'s structure now; False when the worker is busy."""
        return self._started().prepare(key)

    def cancel(self) -> None:
        if self._worker is not None:
            self._worker.cancel()

    def close(self) -> None:
        if self._worker is not None:
            self._worker.close()
            self._worker = None

    def _started(self) -> SolverWorker:
        if self._worker is None:
            worker = SolverWorker(build_gait_problem)
            worker.on_progress(self._on_progress)
            worker.on_done(lambda job_id, result: self._on_end(job_id, result=result))
            # a failure may have crashed and restarted the worker; a cancel restarts it
            worker.on_failed(lambda job_id, message: self._on_end(job_id, message, forget=True))
            worker.on_cancelled(lambda job_id: self._on_end(job_id, "cancelled", forget=True))
            worker.on_prepared(self._on_prepared)
            self._worker = worker
        return self._worker

    def _on_prepared(self, key: object, error: str) -> None:
        if error:  # the solve will meet the same error and report it; keep a trace meanwhile
            log.warning("building the gait problem ahead of time failed: %s", error)
        self.prepared.emit(key)
