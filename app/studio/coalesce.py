"""Latest-only work: keep the newest request per key and never work through a backlog.

Gizmo drags and slider edits arrive on viser's thread pool, every 50 ms per tab, from several
tabs at once. `Coalescer.submit(key, value)` stores the value (replacing one not yet handled)
and returns at once if another thread is already handling requests; otherwise the calling
thread handles whatever is pending, newest value per key, until nothing is left. So a callback
never waits behind another tab's work, and a stale target is never solved.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Hashable
from typing import Generic, TypeVar

K = TypeVar("K", bound=Hashable)
V = TypeVar("V")


class Coalescer(Generic[K, V]):
    def __init__(self, handle: Callable[[K, V], None]) -> None:
        self._handle = handle
        self._pending: dict[K, V] = {}
        self._lock = threading.Lock()
        self._busy = False
        self.received = 0
        """Requests submitted so far."""
        self.handled = 0
        """Requests handled so far (the rest were replaced by newer ones)."""

    def submit(self, key: K, value: V) -> None:
        with self._lock:
            self._pending[key] = value
            self.received += 1
            if self._busy:
                return  # the thread handling requests will take this one
            self._busy = True
        try:
            while True:
                with self._lock:
                    if not self._pending:
                        self._busy = False
                        return
                    key, value = next(iter(self._pending.items()))
                    del self._pending[key]
                self._handle(key, value)
                self.handled += 1
        except BaseException:
            with self._lock:
                self._busy = False
            raise

    @property
    def idle(self) -> bool:
        """No request pending and none being handled."""
        with self._lock:
            return not self._busy and not self._pending
