"""Presenter only (`serve --presenter-only`): two real websocket tabs on a real studio. The
second tab's slider edit is refused before any callback runs (the state and the slider keep
their values, the tab is sent the server's value back and told); the first tab's edit goes
through; with the setting off, the second tab edits like any other. A test here also fails
loudly if viser stops dispatching GUI edits the way app.web.gui_gate expects."""

from __future__ import annotations

import numpy as np
import pytest
import viser
from viser import _messages as viser_messages

from app.config import StudioConfig
from app.studio import Studio
from app.web.gui_gate import gate_gui_edits
from app.web.hook import ViserHookError
from tests.studio.conftest import free_port
from tests.studio.ws_tab import Tab, loop, wait

__all__ = ["loop"]  # the fixture, used by name


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
    wait("the first tab", lambda: len(studio.web.server.get_clients()) == 1)
    second = Tab(studio, loop)
    wait("the second tab", lambda: len(studio.web.server.get_clients()) == 2)
    return first, second


def test_a_viewer_cannot_edit_but_the_presenter_can(tmp_path, loop):
    studio = _studio(tmp_path, presenter_only=True)
    try:
        presenter, viewer = _two_tabs(studio, loop)
        assert studio.presenting.demo.editor == min(studio.web.server.get_clients())
        name, edit = _edit(studio, 12.0)
        slider = studio.joints.panel.sliders[name]
        q_before, value_before = studio.state.q.copy(), slider.value
        assert value_before != 12.0

        viewer.send(edit)
        wait("the refusal", lambda: studio.presenting.demo.refused == 1)
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
        assert studio.presenting.demo.refused == 1

        # The presenter leaves: the viewer is now the oldest tab, and may edit.
        presenter.close()
        wait("the presenter to leave", lambda: len(studio.web.server.get_clients()) == 1)
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
        assert studio.presenting.demo.refused == 0
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
