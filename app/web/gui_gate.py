"""Refusing a tab's edits before the studio sees them (demo mode's *presenter only*).

viser 1.1.1 dispatches a tab's GUI edit (a slider moved, a box ticked, a button clicked: one
`GuiUpdateMessage`), an upload's start (`FileTransferStartUpload`) and a keyboard command
(`CommandTriggerMessage`) to handlers the server-wide `GuiApi` registers on its websocket
interface (`GuiApi._handle_gui_updates` and friends, in `_websock_interface._incoming_handlers`).
`gate_gui_edits` swaps each of those handlers, in place, for one that first asks
`allowed(client_id)`: a refused edit never reaches viser's handler, so no handle changes value
and no callback runs; the tab's widget is sent back the server's value and `on_refused` is told.

The swap is checked: if viser no longer registers the handlers this module names,
`gate_gui_edits` raises `ViserHookError` rather than let viewers edit unchecked
(tests/studio/test_presenter_only.py runs it on every test run). Per-tab folders (the Demo
folder, built on a `ClientHandle`'s own GuiApi) have their own handlers and stay usable.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from typing import Any

import viser

from app.web.viser_internals import (
    GuiUpdateMessage,
    gui_edit_handlers,
    gui_input_values,
    send_gui_values,
)


def gate_gui_edits(
    server: viser.ViserServer,
    allowed: Callable[[int], bool],
    on_refused: Callable[[int], None],
) -> None:
    """From now on, edits from tabs that `allowed` refuses are dropped and undone in the tab."""
    for slot in gui_edit_handlers(server):  # all found, or ViserHookError before any swap
        slot.replace(_gated(server, slot.original, slot.message_cls, allowed, on_refused))


def _gated(
    server: viser.ViserServer,
    original: Callable[..., Any],
    message_cls: type,
    allowed: Callable[[int], bool],
    on_refused: Callable[[int], None],
) -> Callable[..., Any]:
    is_async = inspect.iscoroutinefunction(original)

    async def handler(client_id: int, message: Any) -> None:
        if allowed(client_id):
            result = original(client_id, message)
            if is_async:
                await result
            return
        if message_cls is GuiUpdateMessage:
            _snap_back(server, client_id, message)
        on_refused(client_id)

    return handler


def _snap_back(server: viser.ViserServer, client_id: int, message: Any) -> None:
    """Send the refused tab the server's values of what it changed (its widget moved)."""
    client = server.get_clients().get(client_id)
    values = gui_input_values(server, message.uuid, message.updates)
    if client is not None and values:
        send_gui_values(client, message.uuid, values)
