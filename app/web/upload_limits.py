"""Uploads bounded while they stream in.

viser's upload button sends a file over the websocket as `FileTransferStartUpload`
(name, `size_bytes`, `part_count`) then `FileTransferPart`s (512 KiB each from viser's
client), and viser keeps every part in memory until the last one arrives, with no size
check. `bound_uploads` registers handlers that run right after viser's own for these
two messages (handlers of one message run back to back on viser's event loop, so
nothing else sees the state in between) and drop a transfer, freeing its parts, when:

- at the start: the declared size is over the limit (or negative), the part count is
  implausible (`part_count > size_bytes // MIN_AVERAGE_PART_BYTES + 1`: a flood of tiny
  parts would cost memory per part, not per byte), the client already has
  `max_unfinished` transfers in flight, or the sizes declared by all unfinished
  transfers of all tabs would pass `max_total_bytes` (many tabs cannot add up either);
- on every part: the bytes received so far exceed the declared size or the limit.

A dropped transfer's later parts are ignored by viser (unknown transfer id), so the
memory held per transfer stays below `max_bytes` + one websocket message. The client
that sent it gets a notification saying why. Only the server-wide GUI (`server.gui`)
is bounded: the studio puts its upload buttons there.
"""

from __future__ import annotations

import dataclasses
import threading
from typing import Any

import viser

from app.web.viser_internals import (
    FileTransferPart,
    FileTransferStartUpload,
    upload_states,
    websock_server,
)

MIN_AVERAGE_PART_BYTES = 1024
MAX_UNFINISHED_UPLOADS = 2
TOTAL_PER_FILE_LIMIT = 4
"""Default `max_total_bytes`: this many files at the size limit, over all tabs."""


@dataclasses.dataclass(frozen=True)
class UploadLimits:
    max_bytes: int
    """Largest file accepted, in bytes (declared and received)."""
    max_unfinished: int = MAX_UNFINISHED_UPLOADS
    """Transfers one client may have in flight at once."""
    max_total_bytes: int | None = None
    """Sum of the declared sizes of all unfinished transfers; None: 4 x `max_bytes`."""

    @property
    def total_bytes(self) -> int:
        if self.max_total_bytes is not None:
            return self.max_total_bytes
        return TOTAL_PER_FILE_LIMIT * self.max_bytes


@dataclasses.dataclass(frozen=True)
class DroppedUpload:
    client_id: int
    filename: str
    reason: str


class UploadGuard:
    """Drops uploads over `limits` from `server.gui` as they stream (see module docstring)."""

    def __init__(self, server: viser.ViserServer, limits: UploadLimits) -> None:
        if limits.max_bytes < 0 or limits.max_unfinished < 1:
            raise ValueError(
                f"upload limits must be non-negative with max_unfinished >= 1, got {limits}"
            )
        self.server = server
        self.limits = limits
        self.dropped: list[DroppedUpload] = []
        """Every transfer dropped so far, oldest first (for logs and tests)."""
        self._lock = threading.Lock()
        # viser's per-transfer state: {transfer_uuid: {"client_id", "filename", "parts",
        # "part_count", "total_bytes", "transferred_bytes", ...}} (viser 1.1.1 `GuiApi`).
        self._states: dict[str, dict[str, Any]] = upload_states(server)
        connection = websock_server(server)
        connection.register_handler(FileTransferStartUpload, self._on_start)
        connection.register_handler(FileTransferPart, self._on_part)

    def held_bytes(self) -> int:
        """Bytes of unfinished uploads viser holds in memory right now."""
        return sum(
            len(part)
            for state in list(self._states.values())
            for part in list(state["parts"].values())
        )

    def declared_bytes(self) -> int:
        """Sum of the sizes declared by the unfinished uploads of all clients."""
        return sum(int(state["total_bytes"]) for state in list(self._states.values()))

    def unfinished(self, client_id: int) -> int:
        return sum(1 for state in list(self._states.values()) if state["client_id"] == client_id)

    def _on_start(self, client_id: int, message: FileTransferStartUpload) -> None:
        if message.transfer_uuid not in self._states:
            return  # viser ignored it (no such upload button)
        limit = self.limits.max_bytes
        if not 0 <= message.size_bytes <= limit:
            reason = (
                f"{message.filename!r} is {_mb(message.size_bytes)}; "
                f"uploads are limited to {_mb(limit)}"
            )
        elif message.part_count > message.size_bytes // MIN_AVERAGE_PART_BYTES + 1:
            reason = (
                f"{message.filename!r} was sent in {message.part_count} parts; refused as malformed"
            )
        elif self.unfinished(client_id) > self.limits.max_unfinished:
            reason = (
                f"more than {self.limits.max_unfinished} uploads at once from this tab; "
                "wait for one to finish"
            )
        elif self.declared_bytes() > self.limits.total_bytes:
            reason = (
                f"the studio is already receiving {_mb(self.declared_bytes() - message.size_bytes)} "
                "of uploads; try again when they finish"
            )
        else:
            return
        self._drop(client_id, message.transfer_uuid, reason)

    def _on_part(self, client_id: int, message: FileTransferPart) -> None:
        state = self._states.get(message.transfer_uuid)
        if state is None:
            return
        received = int(state["transferred_bytes"])
        if received > min(self.limits.max_bytes, int(state["total_bytes"])):
            reason = (
                f"{state['filename']!r} sent {_mb(received)}, more than it declared "
                f"({_mb(int(state['total_bytes']))}) or the limit ({_mb(self.limits.max_bytes)})"
            )
            self._drop(client_id, message.transfer_uuid, reason)

    def _drop(self, client_id: int, transfer_uuid: str, reason: str) -> None:
        state = self._states.pop(transfer_uuid, None)
        if state is None:
            return
        state["parts"].clear()
        with self._lock:
            self.dropped.append(DroppedUpload(client_id, str(state["filename"]), reason))
        client = self.server.get_clients().get(client_id)
        if client is not None:
            client.add_notification("Upload refused", reason, color="red", auto_close_seconds=15.0)


def _mb(n_bytes: int) -> str:
    return f"{n_bytes / 1e6:.1f} MB"
