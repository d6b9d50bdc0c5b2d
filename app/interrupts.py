"""Ctrl+C that no library can swallow: the command line's SIGINT handler notes the interrupt
before raising KeyboardInterrupt, so an interrupt caught on its way (trimesh imports its
optional parts under `except BaseException`: a Ctrl+C there left a half-imported trimesh, a
later TypeError, and a studio that went on starting) still stops the command."""

from __future__ import annotations

import signal
import threading
from types import FrameType

_interrupted = threading.Event()


def _on_sigint(signum: int, frame: FrameType | None) -> None:
    _interrupted.set()
    raise KeyboardInterrupt


def install() -> None:
    """Handle Ctrl+C this way in this process (from its main thread)."""
    signal.signal(signal.SIGINT, _on_sigint)


def interrupted() -> bool:
    """Whether Ctrl+C was pressed, even if whatever it interrupted swallowed it."""
    return _interrupted.is_set()


def stop_if_interrupted() -> None:
    """Raise KeyboardInterrupt if Ctrl+C was pressed and swallowed on the way."""
    if _interrupted.is_set():
        raise KeyboardInterrupt
