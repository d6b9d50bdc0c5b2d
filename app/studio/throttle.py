"""At most one call per period, and always the last value: for display work that playback asks
for at 60 Hz but a browser needs a few times a second (the plots' time cursor, a following
camera).

`Throttle.submit(value)` keeps the value (replacing one kept before) and returns at once; a
named timer thread calls `action` with the newest kept value as soon as the last call is a
period old. So a burst costs one call per period, the value the burst ended on is always
shown, and the caller (playback, holding the state's lock) never waits for the action.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Generic, TypeVar

V = TypeVar("V")


class Throttle(Generic[V]):
    def __init__(self, period_s: float, action: Callable[[V], None], name: str) -> None:
        self._period_s, self._action, self._name = period_s, action, name
        self._lock = threading.Lock()
        self._last_s = -float("inf")
        self._pending: list[V] = []
        """The newest value not yet handed to `action` (at most one)."""
        self._timer: threading.Timer | None = None
        self._calling = threading.Lock()
        """Calls of `action` one at a time, in the order of their values."""
        self.calls = 0
        """Calls of `action` so far."""

    def submit(self, value: V) -> None:
        with self._lock:
            self._pending = [value]
            if self._timer is None:
                wait_s = max(0.0, self._last_s + self._period_s - time.monotonic())
                self._timer = threading.Timer(wait_s, self._flush)
                self._timer.name, self._timer.daemon = self._name, True
                self._timer.start()

    def _flush(self) -> None:
        with self._lock:
            self._timer = None
            if not self._pending:
                return
            value = self._pending.pop()
            self._last_s = time.monotonic()
        self._call(value)

    def _call(self, value: V) -> None:
        with self._calling:
            self.calls += 1
            self._action(value)

    def cancel(self) -> None:
        """Drop a kept value (e.g. when what it was for is gone)."""
        with self._lock:
            self._pending = []
            if self._timer is not None:
                self._timer.cancel()
                self._timer = None
