"""Buttons bound to actions: a click calls its action with the tab that clicked.

Most buttons of a panel do exactly that, so a panel lists them as (button, action) pairs
instead of one decorated function each; an action that also takes the panel's inputs is given
as a function of the tab that reads them at the click. What an action returns (a status, a
saved path) is dropped: viser's callbacks return None.
"""

from __future__ import annotations

from collections.abc import Callable

import viser

TabAction = Callable[[viser.ClientHandle | None], object]
"""An action of a panel's Protocol that takes the acting tab (None: from the studio itself)."""


def bind_clicks(*bindings: tuple[viser.GuiButtonHandle, TabAction]) -> None:
    """On each button's click, call its action with the clicking tab."""
    for button, action in bindings:
        button.on_click(_caller(action))


def _caller(action: TabAction) -> Callable[[viser.GuiEvent], None]:
    def call(event: viser.GuiEvent) -> None:
        action(event.client)

    return call
