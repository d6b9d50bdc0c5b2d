"""How much slow work the studio takes at once: a few jobs per tab and a few in all.

viser runs callbacks on a bounded thread pool. A tab (or a hostile page) that clicks *Open
path* forty times must not hold every thread while other tabs wait: a request beyond the
limits is refused at once with a message, instead of queueing.
"""

from __future__ import annotations

import contextlib
import threading
from collections.abc import Iterator

PER_CLIENT = 2
"""Slow jobs (loads, uploads, motion generation) one tab may have running at once."""
TOTAL = 4
"""Slow jobs all tabs together may have running at once."""


class Busy(Exception):
    """The request was not admitted; the message says why."""


class Admission:
    def __init__(
        self,
        per_client: int = PER_CLIENT,
        total: int = TOTAL,
        *,
        busy_tab: str = "this tab already has {n} jobs running; wait for them to finish",
        busy_studio: str = "the studio is busy with other tabs' work; try again in a moment",
    ) -> None:
        """`busy_tab` (formatted with n, the tab's running jobs) and `busy_studio` are the
        refusals' messages."""
        self._per_client, self._total = per_client, total
        self._busy_tab, self._busy_studio = busy_tab, busy_studio
        self._running: dict[int | None, int] = {}
        self._lock = threading.Lock()

    @contextlib.contextmanager
    def admit(self, client_id: int | None) -> Iterator[None]:
        """Run the body as one job of `client_id` (None: the studio itself), or raise Busy."""
        with self._lock:
            mine = self._running.get(client_id, 0)
            if mine >= self._per_client:
                raise Busy(self._busy_tab.format(n=mine))
            if sum(self._running.values()) >= self._total:
                raise Busy(self._busy_studio)
            self._running[client_id] = mine + 1
        try:
            yield
        finally:
            with self._lock:
                self._running[client_id] -= 1
                if not self._running[client_id]:
                    del self._running[client_id]
