"""The Dask engine of the studio's sweeps, and the preparing of its workers.

The engine is made on first use (a local cluster, its worker processes niced) and kept for later
sweeps; a sweep asking for another number of workers replaces it; `close` ends it with the
studio. Preparing (`serve` does it): once the studio has started (`start_preparing`, so its
start is not slowed) and whenever a robot loads, a low-priority thread, "sweep-prepare", has
every worker build the loaded robot's gait NLP at the panel's knots and solve its anchor gait,
so the first point of a sweep pays only its solve; `on_prepared` announces it.
"""

from __future__ import annotations

import contextlib
import logging
import os
import threading
from collections.abc import Callable
from concurrent.futures import CancelledError
from typing import Any

from app.core.errors import StudioError
from app.core.sweeps.sampling import SweepPoint
from app.studio.signals import Signal

log = logging.getLogger(__name__)

WORKER_NICENESS = 10
"""The studio's sweep workers run below the studio itself, so a sweep (and the preparing of
one) leaves the studio responsive."""

PreparePlan = Callable[[], "tuple[SweepPoint, int] | None"]
"""What to prepare now: the anchor point of the loaded robot's sweep and the number of workers,
or None when nothing should be prepared (a sweep is running)."""


class SweepWorkers:
    """The sweeps' engine (made, replaced, closed) and the "sweep-prepare" thread."""

    def __init__(
        self, prepare: bool, plan: PreparePlan, prepared: Callable[[SweepPoint], None]
    ) -> None:
        self._prepare = prepare
        self._plan = plan
        self._on_ready = prepared
        """Called (on "sweep-prepare") with the point prepared, before `on_prepared`."""
        self._engine_lock = threading.Lock()
        """Held while the engine is made or replaced (the runner, the preparer, the loader)."""
        self._engine: Any = None
        self._closed = False
        self._prepare_lock = threading.Lock()
        """Guards the two below: at most one "sweep-prepare" thread runs."""
        self._preparer: threading.Thread | None = None
        self._prepare_wanted = False
        """A robot loaded since the preparer started its round: it goes round again."""
        self._armed = False
        """Set by `start_preparing` once the studio has started: from then on every robot load
        prepares the workers (the studio's own start is not slowed by it)."""
        self.prepared_s: dict[str, float] = {}
        """What the last preparing cost each worker [s] (0.0 where it was warm)."""
        self.prepared = threading.Event()
        """Set when the workers have been prepared once (`prepared_s` says what it cost)."""
        self.on_prepared: Signal[dict[str, float]] = Signal("on_prepared")

    @property
    def engine(self) -> Any:
        """The engine as it is now (None before the first sweep or prepare)."""
        return self._engine

    def engine_for(self, workers: int) -> Any:
        """The engine with `workers` workers: the current one, or a new local cluster (niced
        workers) replacing it."""
        from app.sweep_engine import SweepEngine

        with self._engine_lock:
            if self._closed:
                raise StudioError("the studio is closing")
            engine = self._engine
            # the size the local cluster was started with, not the scheduler's count of the
            # moment: under load a worker can be briefly unregistered, and replacing the
            # cluster then throws away the NLPs its workers were prepared with
            if engine is not None and engine.local_size == workers:
                return engine
            if engine is not None:
                engine.close()
            self._engine = None
            engine = SweepEngine(n_workers=workers)
            with contextlib.suppress(Exception):  # a platform without priorities: run as is
                for pid in engine.worker_pids().values():
                    os.setpriority(os.PRIO_PROCESS, pid, WORKER_NICENESS)
            self._engine = engine
            return engine

    def start_preparing(self) -> None:
        """The studio has started: with `prepare`, prepare the workers for the loaded robot
        now and for every robot loaded later."""
        if self._prepare and not self._armed:
            self._armed = True
            self.prepare_workers()

    def robot_loaded(self) -> None:
        """A robot loaded: prepare for it once the studio has started preparing."""
        if self._armed:
            self.prepare_workers()

    def prepare_workers(self) -> None:
        """Start the cluster and build the swept robot's NLP (at the panel's knots) and its
        anchor gait on every worker, on the low-priority thread "sweep-prepare". One preparer
        at a time: robots loaded while it works (50 project opens in a row) are folded into
        one more round, for the robot loaded last."""
        with self._prepare_lock:
            self._prepare_wanted = True
            if self._preparer is not None:
                return  # the running preparer goes round once more, for the latest robot
            self._preparer = threading.Thread(
                target=self._prepare_rounds, name="sweep-prepare", daemon=True
            )
            self._preparer.start()

    def _prepare_rounds(self) -> None:
        with contextlib.suppress(Exception):  # this thread only: the studio keeps its priority
            os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), WORKER_NICENESS)
        while True:
            with self._prepare_lock:
                if not self._prepare_wanted or self._closed:
                    self._preparer = None
                    return
                self._prepare_wanted = False
            self._prepare_now()

    def _prepare_now(self) -> None:
        try:
            plan = self._plan()
            if plan is None:
                return  # a sweep is running: its points build what they need
            point, workers = plan
            self.prepared_s = self.engine_for(workers).prepare(point)
        except CancelledError as error:  # the engine was replaced or closed meanwhile
            log.info("preparing the sweep workers was interrupted: %s", type(error).__name__)
            return
        except StudioError as error:  # this robot cannot be swept (said again by Run)
            log.info("the sweep workers are not prepared: %s", error)
            return
        except Exception:  # background work: the first sweep will build what it needs
            if not self._closed:
                log.exception("preparing the sweep workers failed")
            return
        self._on_ready(point)
        self.prepared.set()
        self.on_prepared.emit(self.prepared_s)

    def close(self) -> None:
        """End the engine; no other is made after."""
        with self._engine_lock:  # waits for an engine being made, then no other is made
            self._closed = True
            engine, self._engine = self._engine, None
        if engine is not None:
            engine.close()
