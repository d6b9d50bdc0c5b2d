"""A real websocket tab for studio tests: viser's own client protocol (its first camera
message makes it a connected client), recording every message the server sends it."""

from __future__ import annotations

import asyncio
import threading

import pytest
import websockets
from viser import _messages as viser_messages

from app.studio import Studio
from app.web.access import cookie_name
from tests.studio.conftest import GUARD_S
from tests.viser_wire import CAMERA, SUBPROTOCOL, decode_window, encode

__all__ = ["CAMERA", "Tab", "loop", "wait"]


def wait(what: str, probe) -> None:
    done = threading.Event()

    def poll() -> None:
        while not probe():
            if done.wait(0.05):
                return
        done.set()

    thread = threading.Thread(target=poll, daemon=True)
    thread.start()
    ok = done.wait(GUARD_S)
    done.set()
    assert ok, f"timed out waiting for {what}"


class Tab:
    """One websocket tab: connected (its first camera message sent), recording what it gets."""

    def __init__(self, studio: Studio, loop: asyncio.AbstractEventLoop) -> None:
        self.received: list[dict] = []
        self._loop = loop
        port = studio.server.get_port()

        async def connect():
            return await websockets.connect(
                f"ws://127.0.0.1:{port}/",
                additional_headers={
                    "Cookie": f"{cookie_name(port)}={studio.config.token}",
                    "Origin": f"http://127.0.0.1:{port}",
                },
                subprotocols=[websockets.Subprotocol(SUBPROTOCOL)],
                max_size=None,
                open_timeout=60,
            )

        self._ws = asyncio.run_coroutine_threadsafe(connect(), loop).result(GUARD_S)
        asyncio.run_coroutine_threadsafe(self._read(), loop)
        self.send(CAMERA)

    async def _read(self) -> None:
        async for frame in self._ws:
            if isinstance(frame, bytes):
                self.received.extend(decode_window(frame))

    def send(self, message: viser_messages.Message) -> None:
        asyncio.run_coroutine_threadsafe(self._ws.send(encode(message)), self._loop).result(60)

    def close(self) -> None:
        asyncio.run_coroutine_threadsafe(self._ws.close(), self._loop).result(60)


@pytest.fixture
def loop():
    loop = asyncio.new_event_loop()
    thread = threading.Thread(target=loop.run_forever, daemon=True)
    thread.start()
    yield loop
    loop.call_soon_threadsafe(loop.stop)
    thread.join()
