"""`sweep --scheduler ADDRESS` against endpoints that are not Dask schedulers: one that answers
garbage (Dask allocated the frame size it read: MemoryError), and one that sends a huge first frame. Each is one line naming the address. (A peer that
accepts and stays silent still makes Dask's client wait: an attempt on an abandoned thread
deadlocked Dask's shared loop runner for later clusters in the same process; left open.)"""

from __future__ import annotations

import socket
import struct
import threading
from collections.abc import Iterator

import pytest

from app.sweep_engine import SweepEngine, SweepEngineError

PEERS = {
    "garbage": b"HTTP/1.1 200 OK\r\n\r\nnot a scheduler" * 8,
    "huge frame": struct.pack("<Q", 1) + struct.pack("<Q", 2**62) + b"x" * 20,
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
