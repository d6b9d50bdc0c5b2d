"""viser's websocket protocol as a test client speaks it: the subprotocol, a client message
encoded as viser's client sends it, the first camera message (viser counts a tab as connected
from it), and the server's frames decoded. Shared by the web-door tests and the studio's
websocket tabs."""

from __future__ import annotations

import msgspec
import viser
import zstandard
from viser import _messages as viser_messages

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
"""A tab's starting camera."""


def encode(message: viser_messages.Message) -> bytes:
    """A client-to-server message as viser's client sends it (msgpack with a `type`)."""
    return msgspec.msgpack.encode(message.as_serializable_dict())


def decode_window(frame: bytes) -> list[dict]:
    """The messages of one server frame (viser's wire format: sizes, zstd msgpack, buffers)."""
    size, compressed = int.from_bytes(frame[:8], "little"), int.from_bytes(frame[8:16], "little")
    inner = zstandard.ZstdDecompressor().decompress(frame[16 : 16 + compressed], size)
    return list(msgspec.msgpack.decode(inner)["messages"])
