"""panels/clicks.py: a button bound with `bind_clicks` calls its action with the tab that
clicked (a real websocket tab speaking viser's protocol, tests/studio/ws_tab.py), each button
its own action, and an action's return value does not disturb viser."""

from __future__ import annotations

from viser import _messages as viser_messages

from panels.clicks import bind_clicks
from tests.studio.ws_tab import Tab, loop, wait

__all__ = ["loop"]  # the fixture, used by name


def _click(tab: Tab, button) -> None:
    tab.send(viser_messages.GuiUpdateMessage(button._impl.uuid, {"value": True}))


def test_each_button_calls_its_action_with_the_clicking_tab(studio, loop) -> None:
    gui = studio.web.server.gui
    first, second = gui.add_button("First"), gui.add_button("Second")
    calls: list[tuple[str, object]] = []

    def on_first(client) -> str:
        calls.append(("first", client))
        return "a status the panel drops"

    bind_clicks((first, on_first), (second, lambda client: calls.append(("second", client))))

    tab = Tab(studio, loop)
    wait("the tab", lambda: len(studio.web.server.get_clients()) == 1)
    (client,) = studio.web.server.get_clients().values()

    _click(tab, second)
    wait("the second button's action", lambda: len(calls) == 1)
    _click(tab, first)
    wait("the first button's action", lambda: len(calls) == 2)
    assert [name for name, _ in calls] == ["second", "first"]
    assert all(who is not None and who.client_id == client.client_id for _, who in calls)
