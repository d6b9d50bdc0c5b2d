"""`sweep --scheduler ADDRESS` against endpoints that are not Dask schedulers: one that accepts
and stays silent (Dask's client waited forever), one that answers garbage (Dask allocated the
frame size it read: MemoryError), one that sends a short frame and closes. Each is one line
naming the address, in bounded time."""

from __future__ import annotations

import socket
import struct
import threading
from collections.abc import Iterator

import pytest

from app.sweep_engine import SweepEngine, SweepEngineError

PEERS = {
    "silent": None,
    "garbage": b"HTTP/1.1 200 OK\r\n\r\nnot a scheduler" * 8,
    "huge frame": struct.pack("<Q", 1) + struct.pack("<Q", 2**62) + b"x" * 20,
    "short frame": b"\x01\x00",
}


@pytest.fixture
def peer(request) -> Iterator[str]:
    payload = PEERS[request.param]
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(8)
    held: list[socket.socket] = []

    def accept() -> None:
        while True:
            try:
                connection, _ = server.accept()
            except OSError:
                return
            held.append(connection)
            if payload is not None:
                connection.sendall(payload)

    threading.Thread(target=accept, daemon=True).start()
    yield f"tcp://127.0.0.1:{server.getsockname()[1]}"
    server.close()
    for connection in held:
        connection.close()


@pytest.mark.parametrize("peer", list(PEERS), indirect=True)
def test_a_peer_that_is_not_a_scheduler_is_one_line(peer: str) -> None:
    with pytest.raises(SweepEngineError) as refused:
        SweepEngine(peer)
    message = str(refused.value)
    assert peer in message and "\n" not in message
