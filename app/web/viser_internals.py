"""Every reach into viser's private API, in one module, for the one viser version it was read on.

viser 1.1.1 offers no public way to do what the studio needs here: hook its web server before
it answers (app.web.hook), run every callback inside one guard (app.web.callback_guard),
refuse a tab's edits (app.web.gui_gate), bound uploads as they stream (app.web.upload_limits),
turn off the share tunnel (app.web.guard), queue a node's pose without the setter's checks
(app.views.pose_push) and name a checkbox's input element (panels.swatches). Those modules
call the functions below and touch nothing private themselves (tests/test_viser_internals.py
checks the whole source for it).

`PINNED_VISER` is the version in pyproject.toml (`viser==1.1.1`, a test keeps them equal);
`check_viser_version` refuses any other one, because each function below was written against
that version's source. To move to a new viser: read the names below in its source, update
them, the pin and `PINNED_VISER` together, and run tests/test_viser_internals.py.
"""

from __future__ import annotations

import contextlib
import dataclasses
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from types import ModuleType
from typing import Any

import viser
import viser.infra._infra as _infra
from viser import _messages

PINNED_VISER = "1.1.1"
"""The viser version every reach below was read on (pyproject.toml pins it)."""

GuiUpdateMessage = _messages.GuiUpdateMessage
"""A tab's edit of a GUI input (uuid, updates)."""
FileTransferStartUpload = _messages.FileTransferStartUpload
"""An upload's start (transfer_uuid, filename, size_bytes, part_count)."""
FileTransferPart = _messages.FileTransferPart
"""One part of an upload (transfer_uuid, part, content)."""
CommandTriggerMessage = _messages.CommandTriggerMessage
"""A keyboard command from a tab."""
FileTransferPartAck = _messages.FileTransferPartAck
"""The server's receipt of an upload's bytes so far (the uploading tab's progress)."""

_GATED_GUI_HANDLERS: tuple[tuple[type, str], ...] = (
    (GuiUpdateMessage, "_handle_gui_updates"),
    (FileTransferStartUpload, "_handle_file_transfer_start"),
    (CommandTriggerMessage, "_handle_command_trigger"),
)
"""(message, GuiApi method handling it) of every edit a tab can make to the server-wide GUI."""


class ViserHookError(RuntimeError):
    """viser no longer works the way this module expects: the studio refuses to run unguarded."""


def check_viser_version(version: str | None = None) -> None:
    """Raise ViserHookError unless viser (or `version`) is PINNED_VISER."""
    found = viser.__version__ if version is None else version
    if found != PINNED_VISER:
        raise ViserHookError(
            f"viser {found} is installed; the studio reaches into viser {PINNED_VISER}'s "
            f"internals (app/web/viser_internals.py): install viser=={PINNED_VISER}"
        )


# --- the web server -------------------------------------------------------------------------


def viser_websockets() -> Any:
    """The `websockets` module as viser's server code sees it."""
    return _infra.websockets


@contextlib.contextmanager
def websockets_seen_by_viser(replacement: ModuleType | Any) -> Iterator[None]:
    """viser's server code sees `replacement` as `websockets` inside the block (the caller
    holds a lock: the name is module-wide)."""
    real = _infra.websockets
    _infra.websockets = replacement
    try:
        yield
    finally:
        _infra.websockets = real


def websock_server(server: viser.ViserServer) -> Any:
    """The server's websocket server (`register_handler`, `unregister_handler`)."""
    return server._websock_server


def refuse_share_tunnel(server: viser.ViserServer) -> None:
    """Drop viser's handler that opens a public share.viser.studio tunnel on a client's request."""
    server._websock_server.unregister_handler(_messages.ShareUrlRequest)


def callback_executor(server: viser.ViserServer) -> ThreadPoolExecutor:
    """The thread pool every plain `def` callback of the server runs on."""
    executor = getattr(server, "_thread_executor", None)
    if not isinstance(executor, ThreadPoolExecutor):
        raise ViserHookError(
            "viser no longer runs callbacks on ViserServer._thread_executor: "
            "the studio cannot report their failures"
        )
    return executor


# --- the server-wide GUI ---------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class HandlerSlot:
    """Where viser keeps the server-wide GUI's handler of one kind of tab edit."""

    message_cls: type
    original: Callable[..., Any]
    """viser's handler (a GuiApi method; async or not)."""
    registered: list[Callable[..., Any]]
    """viser's own list of the message's handlers (live)."""
    index: int

    def replace(self, handler: Callable[..., Any]) -> None:
        """From now on viser calls `handler` instead of `original`."""
        self.registered[self.index] = handler


def gui_edit_handlers(server: viser.ViserServer) -> list[HandlerSlot]:
    """The handler slot of every edit a tab can make to the server-wide GUI (a GUI input's
    value, an upload's start, a keyboard command); ViserHookError if one is not found."""
    gui: Any = server.gui
    handlers: dict[type, list[Callable[..., Any]]] = gui._websock_interface._incoming_handlers
    slots = []
    for message_cls, name in _GATED_GUI_HANDLERS:
        original = getattr(gui, name, None)
        registered = handlers.get(message_cls, [])
        if original is None or original not in registered:
            raise ViserHookError(
                f"viser no longer handles {message_cls.__name__} with GuiApi.{name}: "
                "presenter-only mode cannot refuse viewers' edits"
            )
        slots.append(HandlerSlot(message_cls, original, registered, registered.index(original)))
    return slots


def gui_input_values(server: viser.ViserServer, uuid: str, fields: Any) -> dict[str, Any]:
    """The server's values of `fields` of the GUI input `uuid` ({} for an unknown input)."""
    gui: Any = server.gui
    handle = gui._gui_input_handle_from_uuid.get(uuid)
    if handle is None:
        return {}
    state = handle._impl
    return {k: getattr(state, k) for k in fields if hasattr(state, k)}


def send_gui_values(client: viser.ClientHandle, uuid: str, values: dict[str, Any]) -> None:
    """Tell one tab the values of the GUI input `uuid` (its widget shows them)."""
    client._websock_connection.queue_message(_messages.GuiUpdateMessage(uuid, values))


def gui_input_id(handle: viser.GuiCheckboxHandle) -> str:
    """The id of a GUI input's element in the page (its label's `for=`)."""
    return str(handle._impl.uuid)


def upload_states(server: viser.ViserServer) -> dict[str, dict[str, Any]]:
    """viser's state of every unfinished upload to the server-wide GUI: {transfer_uuid:
    {"client_id", "filename", "parts", "part_count", "total_bytes", ...}} (a live dict)."""
    gui: Any = server.gui
    return gui._current_file_upload_states


def send_upload_receipts_to_their_tab(server: viser.ViserServer) -> None:
    """From now on an upload's receipts (FileTransferPartAck) go to the tab that uploads only.

    viser 1.1.1 queues them on the server-wide interface: every other open tab, and every tab
    opened later (the server-wide buffer keeps them), showed a notification "Uploading
    undefined (9.9K) — File uploaded successfully" for a file it never sent."""
    gui: Any = server.gui
    interface = gui._websock_interface
    states: dict[str, dict[str, Any]] = gui._current_file_upload_states
    broadcast = interface.queue_message

    def queue_message(message: Any) -> None:
        if not isinstance(message, FileTransferPartAck):
            broadcast(message)
            return
        state = states.get(message.transfer_uuid)  # viser drops it after the last receipt
        client = server.get_clients().get(state["client_id"]) if state is not None else None
        if client is not None:
            client._websock_connection.queue_message(message)

    interface.queue_message = queue_message


# --- the scene -------------------------------------------------------------------------------


def queue_node_pose(
    handle: viser.SceneNodeHandle,
    position: tuple[float, float, float] | None,
    wxyz: tuple[float, float, float, float] | None,
) -> None:
    """Record a node's new position and/or orientation in its handle and queue the messages
    viser's setters would, without their checks."""
    impl = handle._impl
    if impl.removed:
        raise RuntimeError(f"cannot move the removed scene node {impl.name}")
    if position is not None:
        impl.position[:] = position
        impl.api._queue_scene_message(_messages.SetPositionMessage(impl.name, position))
    if wxyz is not None:
        impl.wxyz[:] = wxyz
        impl.api._queue_scene_message(_messages.SetOrientationMessage(impl.name, wxyz))
