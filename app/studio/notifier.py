"""Notifications: what went wrong, said in the tab that asked (or in every tab).

Every failure the user can cause reaches them twice: in the status line of the panel of the
feature that failed (the session writes it) and as a notification from here.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import threading
from collections.abc import Callable, Iterator
from typing import Literal

import viser

from app.core.errors import StudioError

log = logging.getLogger(__name__)

Colour = Literal["red", "green", "yellow", "blue"]


@dataclasses.dataclass(frozen=True)
class Message:
    title: str
    body: str
    colour: Colour


class Notifier:
    def __init__(self, server: viser.ViserServer) -> None:
        self._server = server
        self.last: Message | None = None
        """The last message sent (the studio log shows them all)."""

    def _targets(self, client: viser.ClientHandle | None) -> list[viser.ClientHandle]:
        return [client] if client is not None else list(self._server.get_clients().values())

    def notify(
        self,
        title: str,
        body: str,
        client: viser.ClientHandle | None = None,
        colour: Colour = "green",
    ) -> None:
        self.last = Message(title, body, colour)
        (log.warning if colour == "red" else log.info)("%s: %s", title, body)
        for target in self._targets(client):
            target.add_notification(title, body, color=colour, auto_close_seconds=8.0)

    def error(self, title: str, body: str, client: viser.ClientHandle | None = None) -> None:
        self.notify(title, body, client, "red")

    @property
    def last_error(self) -> str:
        """Body of the last error, "" when the last message was not one."""
        last = self.last
        return last.body if last is not None and last.colour == "red" else ""

    def progress(self, title: str, body: str, client: viser.ClientHandle | None) -> Progress:
        """A loading notification, removed by `Progress.done()`."""
        return Progress(
            [
                c.add_notification(title, body, loading=True, with_close_button=False)
                for c in self._targets(client)
            ]
        )


class Progress:
    """A loading notification in one or more tabs. Once `done`, it is gone: later `say`s are
    dropped (viser raises on a removed handle), and a tab that closed meanwhile is skipped."""

    def __init__(self, handles: list[viser.NotificationHandle]) -> None:
        self._handles = handles
        self._lock = threading.Lock()
        self._done = False

    def say(self, body: str) -> None:
        """Replace the notification's text (the stage a long task is in)."""
        with self._lock:
            if self._done:
                return
            for handle in self._handles:
                with contextlib.suppress(RuntimeError):  # its tab closed meanwhile
                    handle.body = body

    def done(self) -> None:
        with self._lock:
            if self._done:
                return
            self._done = True
            for handle in self._handles:
                with contextlib.suppress(RuntimeError):
                    handle.remove()


@contextlib.contextmanager
def failure_told(
    fail: Callable[[str, str, viser.ClientHandle | None], None],
    title: str,
    client: viser.ClientHandle | None,
    logger: logging.Logger,
) -> Iterator[None]:
    """A worker thread's job (the callback guard does not reach there): a StudioError is told
    through `fail(title, message, client)` as it is; anything else, a bug, is logged with its
    traceback on `logger` and told in one line. Neither escapes: the caller still announces
    the end."""
    try:
        yield
    except StudioError as error:
        fail(title, str(error), client)
    except Exception as error:
        logger.exception(title)
        fail(title, f"{type(error).__name__}: {error}", client)
