"""Demo panel, one per tab: *Follow presenter* makes this tab's camera copy the camera of the
tab that last moved its own."""

from __future__ import annotations

from typing import Protocol

import viser


class DemoActions(Protocol):
    """What a tab's Demo panel asks for."""

    def set_following(self, client: viser.ClientHandle, following: bool) -> None: ...


class DemoPanel:
    """Owns one tab's "Demo" folder (built with that tab's own GUI API)."""

    def __init__(self, client: viser.ClientHandle, actions: DemoActions) -> None:
        gui = client.gui
        with gui.add_folder("Demo", order=8, expand_by_default=False):
            self.follow = gui.add_checkbox(
                "Follow presenter",
                False,
                hint="this tab's camera copies the camera of the tab that last moved its own",
            )
            self.status = gui.add_markdown(
                "Tick *Follow presenter* to watch from the presenter's camera. Every tab "
                "already shares the robot, the motion and the timeline."
            )
        self.follow.on_update(lambda _: actions.set_following(client, bool(self.follow.value)))
