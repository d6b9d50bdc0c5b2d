"""Signals: the studio state announces its changes; sessions subscribe.

A `Signal` calls its subscribers in the order they connected, in the thread that emits (the
state emits while holding its lock, so subscribers see changes one at a time, in order). A
subscriber that raises is logged and the others still run: one feature's bug must not stop the
robot from being drawn.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from typing import Generic, TypeVar

log = logging.getLogger(__name__)

T = TypeVar("T")


class Signal(Generic[T]):
    """A named list of callbacks taking one value."""

    def __init__(self, name: str) -> None:
        self.name = name
        self._callbacks: list[Callable[[T], None]] = []
        self._lock = threading.Lock()

    def connect(self, callback: Callable[[T], None]) -> Callable[[], None]:
        """Call `callback(value)` on every emit; returns a function that disconnects it."""
        with self._lock:
            self._callbacks.append(callback)

        def disconnect() -> None:
            with self._lock:
                if callback in self._callbacks:
                    self._callbacks.remove(callback)

        return disconnect

    def emit(self, value: T) -> None:
        with self._lock:
            callbacks = list(self._callbacks)
        for callback in callbacks:
            try:
                callback(value)
            except Exception:
                log.exception("a subscriber of %s failed", self.name)
