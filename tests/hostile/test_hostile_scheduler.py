"""`sweep --scheduler ADDRESS` against endpoints that are not Dask schedulers. Dask's client
bounds only the TCP connect: a peer that accepts and stays silent, or sends part of a frame and
holds the connection, kept it waiting forever, and it allocated whatever frame size the peer
declared. The address is now probed first (app/scheduler_probe.py): each case is one line
naming the address and what went wrong, exit 1, bounded memory.

The peers that would make a regression hang run through the CLI in a subprocess (its time-out
is the hang detector); the others also run in this process."""

from __future__ import annotations

import socket
import struct
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

from app.scheduler_probe import HANDSHAKE_TIMEOUT_S
from app.sweep_engine import SweepEngine, SweepEngineError
from tests.hostile.cli_runner import assert_refused_in_one_line, run_cli

PEERS: dict[str, tuple[bytes | None, bool]] = {
    # name: (what the peer sends, whether it then closes the connection)
    "garbage": (b"HTTP/1.1 200 OK\r\n\r\nnot a scheduler" * 8, False),
    "huge frame": (struct.pack("<Q", 1) + struct.pack("<Q", 2**62) + b"x" * 20, False),
    "short frame, closed": (b"\x01\x00", True),
    "greeting cut, closed": (struct.pack("<Q", 200) + b"\x00" * 10, True),
    "not msgpack": (struct.pack("<Q", 24) + struct.pack("<Q", 1) + struct.pack("<Q", 8) + b"\xc1" * 8, False),
    # these kept Dask's client waiting forever
    "silent": (None, False),
    "short frame, held": (b"\x01\x00", False),
    # Dask's client allocated the 1.5 GB this declares, then waited for it
    "1.5 GB frame, held": (struct.pack("<Q", 1_500_000_000) + b"x" * 100, False),
}  # fmt: skip
HANGING = ("silent", "short frame, held", "1.5 GB frame, held")
SPEC = """
samples = 2
[[parameter]]
name = "step_length_m"
min = 0.12
max = 0.2
"""


@pytest.fixture
def peer(request) -> Iterator[str]:
    payload, close = PEERS[request.param]
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
            if close:
                connection.close()

    threading.Thread(target=accept, daemon=True).start()
    yield f"tcp://127.0.0.1:{server.getsockname()[1]}"
    server.close()
    for connection in held:
        connection.close()


@pytest.mark.parametrize("peer", [p for p in PEERS if p not in HANGING], indirect=True)
def test_a_peer_that_is_not_a_scheduler_is_one_line(peer: str) -> None:
    with pytest.raises(SweepEngineError) as refused:
        SweepEngine(peer)
    message = str(refused.value)
    assert peer in message and "\n" not in message


WHAT_WENT_WRONG = {
    "garbage": "does not speak Dask's protocol",
    "silent": f"sent no Dask greeting within {HANDSHAKE_TIMEOUT_S:g} s",
    "short frame, held": f"sent no Dask greeting within {HANDSHAKE_TIMEOUT_S:g} s",
    "1.5 GB frame, held": "does not speak Dask's protocol",
}


@pytest.mark.parametrize("peer", list(WHAT_WENT_WRONG), indirect=True)
def test_sweep_on_a_peer_that_is_not_a_scheduler_exits_1_in_one_line(
    peer: str, request: pytest.FixtureRequest, tmp_path: Path
) -> None:
    spec = tmp_path / "sweep.toml"
    spec.write_text(SPEC)
    result = run_cli("sweep", str(spec), "--scheduler", peer, tmp_path=tmp_path)
    # exit 1, one line, no traceback, peak memory bounded (the 1.5 GB frame is not allocated)
    what = WHAT_WENT_WRONG[request.node.callspec.params["peer"]]
    assert_refused_in_one_line(result, f"cannot reach the Dask scheduler at {peer}", what)
