"""No silent failure: a callback that raises while a tab clicks reaches that tab in one line,
its traceback reaches the log, and the studio goes on. Tabs here are real websocket clients
speaking viser's protocol (tests/studio/ws_tab.py): the click travels the path a browser's
does (the server's thread pool), not `handle.value = …` from Python."""

from __future__ import annotations

import types

import pytest
from viser import _messages as viser_messages

from app.web.callback_guard import guard_callbacks
from app.web.hook import ViserHookError
from tests.studio.ws_tab import Tab, loop, wait

__all__ = ["loop"]  # the fixture, used by name


def _notifications(tab: Tab) -> list[str]:
    """Title and body of every notification the tab was shown."""
    return [
        f"{m['props']['title']}: {m['props']['body']}"
        for m in tab.received
        if m.get("type") == "NotificationShowMessage"
    ]


def _click(tab: Tab, button) -> None:
    tab.send(viser_messages.GuiUpdateMessage(button._impl.uuid, {"value": True}))


@pytest.mark.expected_traceback("app.web.callback_guard")
def test_a_callback_that_raises_is_told_to_the_tab_that_clicked(studio, loop) -> None:
    button = studio.web.server.gui.add_button("Fail on purpose")

    @button.on_click
    def _(_event) -> None:
        raise RuntimeError("the part nobody foresaw\nsecond line stays in the log")

    clicker = Tab(studio, loop)
    wait("the first tab", lambda: len(studio.web.server.get_clients()) == 1)
    bystander = Tab(studio, loop)
    wait("the second tab", lambda: len(studio.web.server.get_clients()) == 2)

    _click(clicker, button)
    wait(
        "the clicking tab to be told",
        lambda: any("Something went wrong" in text for text in _notifications(clicker)),
    )
    told = next(text for text in _notifications(clicker) if "Something went wrong" in text)
    assert "*Fail on purpose*" in told
    assert "RuntimeError: the part nobody foresaw" in told
    assert "second line" not in told, "the user gets one line; the log gets the rest"
    assert "work is kept" in told

    assert not any("Something went wrong" in text for text in _notifications(bystander))

    # The studio goes on: the same tab's next action works (alone, so no confirmation).
    bystander.close()
    wait("the second tab to leave", lambda: len(studio.web.server.get_clients()) == 1)
    robot_before = studio.state.robot
    _click(clicker, studio.robots.panel.load_builtin)
    wait(
        "the next click to load the robot",
        lambda: any(text.startswith("Robot loaded") for text in _notifications(clicker)),
    )
    assert studio.state.robot is not robot_before


def test_loading_from_a_tab_shows_the_robot_and_clears_the_loading_note(studio, loop) -> None:
    """The first click of the studio: *Load built-in* from a connected tab (it used to write
    its stage into the loading notification after removing it, raise, and stay "Loading…")."""
    tab = Tab(studio, loop)
    wait("the tab", lambda: len(studio.web.server.get_clients()) == 1)
    panel = studio.robots.panel
    tab.send(viser_messages.GuiUpdateMessage(panel.builtin._impl.uuid, {"value": "dircon_biped"}))
    wait("the dropdown's new value", lambda: panel.builtin.value == "dircon_biped")
    _click(tab, panel.load_builtin)
    wait(
        "the robot loaded",
        lambda: any(text.startswith("Robot loaded: dircon_biped") for text in _notifications(tab)),
    )
    shown = {m["uuid"] for m in tab.received if m.get("type") == "NotificationShowMessage"}
    removed = {m["uuid"] for m in tab.received if m.get("type") == "RemoveNotificationMessage"}
    loading = {
        m["uuid"]
        for m in tab.received
        if m.get("type") == "NotificationShowMessage" and m["props"]["loading"]
    }
    # Shown and removed within one flush of the tab's messages (a fast load), viser sends the
    # tab neither: a loading note is cosmetic, so none at all is fine; one left is not.
    assert loading <= removed, "a loading notification was left in the tab"
    assert shown - loading, "no result notification"
    assert studio.state.robot.name == "dircon_biped"
    assert "dircon_biped" in panel.status.content and "Loading" not in panel.status.content


def test_a_failed_load_puts_the_dropdown_back_on_the_loaded_robot(studio, monkeypatch) -> None:
    import app.studio.robot_session as robot_session

    def refuse(*_args, **_kwargs):
        raise robot_session.StudioError("this robot is refused for the test")

    monkeypatch.setattr(robot_session, "load_robot", refuse)
    panel = studio.robots.panel
    panel.builtin.value = "dircon_biped"
    assert not studio.robots.load("dircon_biped")
    assert panel.builtin.value == studio.state.robot.name == "servo_biped"
    assert "refused for the test" in panel.status.content


def test_without_viser_s_executor_the_guard_refuses_to_start() -> None:
    with pytest.raises(ViserHookError):
        guard_callbacks(types.SimpleNamespace(), lambda *_: None)  # type: ignore[arg-type]
