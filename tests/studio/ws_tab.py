"""A real websocket tab for studio tests: viser's own client protocol (its first camera
message makes it a connected client), recording every message the server sends it."""

from __future__ import annotations

import asyncio
import threading
from collections.abc import Callable

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
        port = studio.web.server.get_port()

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

    render: Callable[[int, int], bytes] | None = None
    """Set it to answer the server's render requests as a browser would: called with the
    requested (height, width), returns the image's bytes (JPEG or PNG, as requested)."""

    async def _read(self) -> None:
        async for frame in self._ws:
            if isinstance(frame, bytes):
                messages = decode_window(frame)
                self.received.extend(messages)
                for message in messages:
                    if message.get("type") == "GetRenderRequestMessage" and self.render:
                        payload = self.render(message["height"], message["width"])
                        await self._ws.send(
                            encode(
                                viser_messages.GetRenderResponseMessage(
                                    payload, message["render_uuid"]
                                )
                            )
                        )

    def download(self) -> tuple[dict, bytes] | None:
        """The newest file the server sent this tab to download: (its start message, its
        content put together from its parts), once every part is in; None before."""
        starts = [m for m in self.received if m.get("type") == "FileTransferStartDownload"]
        if not starts:
            return None
        start = starts[-1]
        parts = {
            m["part_index"]: bytes(m["content"])
            for m in self.received
            if m.get("type") == "FileTransferPart" and m["transfer_uuid"] == start["transfer_uuid"]
        }
        if len(parts) < start["part_count"]:
            return None
        return start, b"".join(parts[i] for i in range(start["part_count"]))

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

    async def drain() -> None:
        """End the tabs' readers and keepalives before the loop stops: destroyed pending tasks
        make asyncio log errors into the next test."""
        tasks = [task for task in asyncio.all_tasks() if task is not asyncio.current_task()]
        for task in tasks:
            task.cancel()
        await asyncio.gather(*tasks, return_exceptions=True)

    asyncio.run_coroutine_threadsafe(drain(), loop).result(60)
    loop.call_soon_threadsafe(loop.stop)
    thread.join()
    loop.close()
