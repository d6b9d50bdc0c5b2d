"""Setting a GUI value from the studio without the panel calling the studio back.

viser fires a handle's update callbacks when Python sets its value; panels that mirror state
(sliders following a drag, a timeline following playback) set values inside `quietly()`, and
their callbacks return early while `quiet` is set.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import Any


class Quiet:
    """A flag for panels: `with self.quietly(): set_value(...)`."""

    def __init__(self) -> None:
        self.quiet = False

    @contextlib.contextmanager
    def quietly(self) -> Iterator[None]:
        self.quiet = True
        try:
            yield
        finally:
            self.quiet = False


def set_value(handle: Any, value: object) -> None:
    """handle.value = value (viser types the value setter on a generic base, which mypy reads
    as read-only; this is the one place that says so)."""
    handle.value = value
