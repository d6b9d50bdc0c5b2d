"""Presenter only (`serve --presenter-only`): two real websocket tabs on a real studio. The
second tab's slider edit is refused before any callback runs (the state and the slider keep
their values, the tab is sent the server's value back and told); the first tab's edit goes
through; with the setting off, the second tab edits like any other. A test here also fails
loudly if viser stops dispatching GUI edits the way app.web.gui_gate expects."""

from __future__ import annotations

import asyncio
import threading

import msgspec
import numpy as np
import pytest
import viser
import websockets
import zstandard
from viser import _messages as viser_messages

from app.config import StudioConfig
from app.studio import Studio
from app.web.access import cookie_name
from app.web.gui_gate import gate_gui_edits
from app.web.hook import ViserHookError
from tests.studio.conftest import GUARD_S, free_port

SUBPROTOCOL = f"viser-v{viser.__version__}"
CAMERA = viser_messages.ViewerCameraMessage(
    wxyz=(1.0, 0.0, 0.0, 0.0),
    position=(1.0, 1.0, 1.0),
    fov=1.0,
    near=0.01,
    far=100.0,
    image_height=600,
    image_width=800,
    look_at=(0.0, 0.0, 0.0),
    up_direction=(0.0, 0.0, 1.0),
)


def encode(message: viser_messages.Message) -> bytes:
    return msgspec.msgpack.encode(message.as_serializable_dict())


def decode_window(frame: bytes) -> list[dict]:
    """The messages of one server frame (viser's wire format: sizes, zstd msgpack, buffers)."""
    size, compressed = int.from_bytes(frame[:8], "little"), int.from_bytes(frame[8:16], "little")
    inner = zstandard.ZstdDecompressor().decompress(frame[16 : 16 + compressed], size)
    return list(msgspec.msgpack.decode(inner)["messages"])


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


def _studio(tmp_path, presenter_only: bool) -> Studio:
    return Studio(
        StudioConfig(port=free_port(), data_dir=tmp_path / "data", presenter_only=presenter_only)
    )


def _edit(studio: Studio, degrees: float) -> tuple[str, viser_messages.GuiUpdateMessage]:
    """A tab's edit of the third joint's slider (a pose change: the state's q moves)."""
    name = studio.state.robot.joints[2].name
    slider = studio.joints.panel.sliders[name]
    return name, viser_messages.GuiUpdateMessage(slider._impl.uuid, {"value": degrees})


def _two_tabs(studio: Studio, loop) -> tuple[Tab, Tab]:
    first = Tab(studio, loop)
    wait("the first tab", lambda: len(studio.server.get_clients()) == 1)
    second = Tab(studio, loop)
    wait("the second tab", lambda: len(studio.server.get_clients()) == 2)
    return first, second


def test_a_viewer_cannot_edit_but_the_presenter_can(tmp_path, loop):
    studio = _studio(tmp_path, presenter_only=True)
    try:
        presenter, viewer = _two_tabs(studio, loop)
        assert studio.demo.editor == min(studio.server.get_clients())
        name, edit = _edit(studio, 12.0)
        slider = studio.joints.panel.sliders[name]
        q_before, value_before = studio.state.q.copy(), slider.value
        assert value_before != 12.0

        viewer.send(edit)
        wait("the refusal", lambda: studio.demo.refused == 1)
        assert np.array_equal(studio.state.q, q_before)
        assert slider.value == value_before
        # The viewer's slider is sent back the server's value.
        wait(
            "the snap-back",
            lambda: any(
                m.get("type") == "GuiUpdateMessage"
                and m.get("uuid") == edit.uuid
                and m.get("updates") == {"value": value_before}
                for m in viewer.received
            ),
        )
        wait("the notice", lambda: any("Presenter only" in str(m) for m in viewer.received))

        presenter.send(edit)
        wait("the presenter's edit", lambda: slider.value == 12.0)
        wait("the pose to follow", lambda: not np.array_equal(studio.state.q, q_before))
        assert studio.demo.refused == 1

        # The presenter leaves: the viewer is now the oldest tab, and may edit.
        presenter.close()
        wait("the presenter to leave", lambda: len(studio.server.get_clients()) == 1)
        viewer.send(_edit(studio, -5.0)[1])
        wait("the new presenter's edit", lambda: slider.value == -5.0)
        viewer.close()
    finally:
        studio.stop()


def test_without_the_setting_any_tab_edits(tmp_path, loop):
    studio = _studio(tmp_path, presenter_only=False)
    try:
        first, second = _two_tabs(studio, loop)
        name, edit = _edit(studio, 12.0)
        q_before = studio.state.q.copy()
        second.send(edit)
        wait("the second tab's edit", lambda: studio.joints.panel.sliders[name].value == 12.0)
        wait("the pose to follow", lambda: not np.array_equal(studio.state.q, q_before))
        assert studio.demo.refused == 0
        first.close()
        second.close()
    finally:
        studio.stop()


def test_the_gate_refuses_to_start_if_viser_changed(tmp_path):
    server = viser.ViserServer(host="127.0.0.1", port=free_port(), verbose=False)
    try:
        gui = server.gui
        handlers = gui._websock_interface._incoming_handlers
        handlers[viser_messages.GuiUpdateMessage].remove(gui._handle_gui_updates)
        with pytest.raises(ViserHookError, match="GuiUpdateMessage"):
            gate_gui_edits(server, lambda _id: False, lambda _id: None)
    finally:
        server.stop()
