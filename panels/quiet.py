"""Setting a GUI value from the studio without the panel calling the studio back.

viser calls a handle's update callbacks synchronously, in the thread that sets its value
(`_GuiInputHandle.value`'s setter), with `client=None`. Panels that mirror state (sliders
following a drag, a timeline following playback) set values inside `quietly()`; their callbacks
ask `is_quiet()` and return early. The flag is per thread: a browser event handled meanwhile on
another thread of viser's pool is never mistaken for the echo and dropped.
"""

from __future__ import annotations

import contextlib
import threading
from collections.abc import Iterator
from typing import Any


class Quiet:
    """A per-thread flag for panels: `with self.quietly(): set_value(...)`."""

    def __init__(self) -> None:
        self._local = threading.local()

    @contextlib.contextmanager
    def quietly(self) -> Iterator[None]:
        depth = getattr(self._local, "depth", 0)
        self._local.depth = depth + 1
        try:
            yield
        finally:
            self._local.depth = depth

    def is_quiet(self) -> bool:
        return getattr(self._local, "depth", 0) > 0


def set_value(handle: Any, value: object) -> None:
    """handle.value = value (viser types the value setter on a generic base, which mypy reads
    as read-only; this is the one place that says so)."""
    handle.value = value
