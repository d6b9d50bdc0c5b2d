"""Check that a scheduler address speaks Dask before a Dask client is made for it.

Dask's client bounds the TCP connect by its `timeout`, not the handshake after it: a peer that
accepts the connection and stays silent, or sends a few bytes of a frame and holds the
connection, keeps `distributed.Client(address)` waiting forever; and it allocates whatever frame
size the peer's first eight bytes declare. Running that client on a thread to abandon it is no
way out (a connect left running deadlocked Dask's shared loop runner for every later cluster in
the process). So `probe_scheduler` first reads the scheduler's greeting on a plain socket, on
the caller's thread, with time-outs and a size bound: a Dask scheduler writes its handshake (a
small msgpack message) as soon as a connection is made, before it reads anything.
"""

from __future__ import annotations

import contextlib
import socket
import ssl
import struct
import time
from typing import Any

CONNECT_TIMEOUT_S = 5.0
"""How long to try reaching a scheduler address [s]."""
HANDSHAKE_TIMEOUT_S = 5.0
"""How long a peer that accepted the connection may take to send Dask's greeting [s]."""
GREETING_MAX_BYTES = 64 * 1024
"""Largest first frame taken for a Dask greeting (a real one is a few hundred bytes)."""


class SchedulerProbeError(Exception):
    """The address is not a Dask scheduler that answers; the message says what went wrong."""


def _recv_exactly(sock: socket.socket, n: int, deadline: float) -> bytes:
    chunks: list[bytes] = []
    received = 0
    while received < n:
        left = deadline - time.monotonic()
        if left <= 0:
            raise TimeoutError
        sock.settimeout(left)
        chunk = sock.recv(min(n - received, 65536))
        if not chunk:
            raise ConnectionResetError("closed")
        chunks.append(chunk)
        received += len(chunk)
    return b"".join(chunks)


def _split_address(address: str) -> tuple[str, str, int]:
    from distributed.comm.addressing import parse_address, parse_host_port

    try:
        scheme, location = parse_address(address)
        host, port = parse_host_port(location)
    except (ValueError, TypeError) as error:
        raise SchedulerProbeError(f"not an address: {error}") from None
    if scheme not in ("tcp", "tls"):
        raise SchedulerProbeError(f"{scheme}:// is not supported: give tcp:// or tls://")
    return scheme, host, int(port)


def probe_scheduler(
    address: str,
    security: Any = None,
    connect_timeout_s: float = CONNECT_TIMEOUT_S,
    handshake_timeout_s: float = HANDSHAKE_TIMEOUT_S,
) -> None:
    """Return when `address` (tcp:// or tls://HOST:PORT) accepts a connection and sends a
    well-formed Dask greeting within the time-outs; raise SchedulerProbeError saying what went
    wrong otherwise. `security` (a `distributed.security.Security`; None: the Dask
    configuration's) gives the TLS context of a tls:// address."""
    scheme, host, port = _split_address(address)
    context: ssl.SSLContext | None = None
    if scheme == "tls":
        from distributed.security import Security

        context = (security or Security()).get_connection_args("client").get("ssl_context")
        if context is None:
            raise SchedulerProbeError(
                "a tls:// scheduler needs TLS credentials: set distributed.comm.tls.* "
                "in your Dask configuration"
            )
    try:
        raw = socket.create_connection((host, port), timeout=connect_timeout_s)
    except TimeoutError:
        raise SchedulerProbeError(f"no connection within {connect_timeout_s:g} s") from None
    except OSError as error:
        raise SchedulerProbeError(f"connection failed: {error.strerror or error}") from None
    with contextlib.closing(raw):
        deadline = time.monotonic() + handshake_timeout_s
        try:
            sock = raw
            if context is not None:
                raw.settimeout(handshake_timeout_s)
                sock = context.wrap_socket(raw, server_hostname=host)
            with contextlib.closing(sock):
                (size,) = struct.unpack("<Q", _recv_exactly(sock, 8, deadline))
                if not 0 < size <= GREETING_MAX_BYTES:
                    raise SchedulerProbeError(
                        "it does not speak Dask's protocol (its first frame is not a greeting)"
                    )
                _check_greeting(_recv_exactly(sock, size, deadline))
        except TimeoutError:
            raise SchedulerProbeError(
                "it accepted the connection but sent no Dask greeting within "
                f"{handshake_timeout_s:g} s: is it a Dask scheduler (a TLS one needs tls://)?"
            ) from None
        except ssl.SSLError as error:
            raise SchedulerProbeError(
                f"the TLS handshake failed: {error.reason or error}"
            ) from None
        except OSError:
            raise SchedulerProbeError(
                "it closed the connection before sending a full Dask greeting"
            ) from None


def _check_greeting(frames: bytes) -> None:
    """The greeting's bytes unpack as Dask frames whose header is msgpack."""
    import msgpack
    from distributed.protocol.utils import unpack_frames

    try:
        parts, _ = unpack_frames(frames, partial=True)
        msgpack.loads(parts[0])
    except Exception:  # any malformed frame: struct, index, msgpack errors alike
        raise SchedulerProbeError(
            "it does not speak Dask's protocol (its greeting does not unpack)"
        ) from None
