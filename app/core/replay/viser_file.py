"""Read a `.viser` recording (viser 1.1's file format) without viser: for checking an export
and for tests that look inside one.

Layout (viser/infra/_infra.py, StateSerializer.serialize): an 8-byte little-endian size of the
inner payload, then the payload zstd-compressed. The payload is an 8-byte little-endian msgpack
length, the msgpack map {durationSeconds, messages: [(t, message dict)…], viserVersion,
binaryBufferLengths}, then the binary buffers, each 8-byte aligned. A message dict holds
`{"__binary_index": i, "dtype": …}` where an array was taken out into buffer i.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import msgspec
import zstandard

from app.core.replay.scene import ReplayError

MAX_PAYLOAD_BYTES = 1 << 30
"""A recording claiming more than 1 GiB uncompressed is refused before it is inflated."""


@dataclasses.dataclass(frozen=True)
class ViserRecording:
    duration_s: float
    viser_version: str
    messages: tuple[tuple[float, dict[str, Any]], ...]
    """(time [s], message as a dict with its "type") in playback order."""
    buffers: tuple[bytes, ...]
    """Binary arrays taken out of the messages, by `__binary_index`."""

    def types(self) -> set[str]:
        return {message["type"] for _, message in self.messages}

    def node_names(self) -> set[str]:
        """Names of the scene nodes the recording creates or moves."""
        return {str(m["name"]) for _, m in self.messages if isinstance(m.get("name"), str)}


def read_viser_file(data: bytes) -> ViserRecording:
    """Decode a `.viser` recording; ReplayError if it is not one."""
    if len(data) < 8:
        raise ReplayError("not a .viser recording: shorter than its 8-byte header")
    size = int.from_bytes(data[:8], "little")
    if size > MAX_PAYLOAD_BYTES:
        raise ReplayError(f"the .viser recording claims {size} bytes uncompressed; too large")
    try:
        payload = zstandard.ZstdDecompressor().decompress(data[8:], max_output_size=size)
    except zstandard.ZstdError as error:
        raise ReplayError(f"not a .viser recording: {error}") from None
    if len(payload) != size or size < 8:
        raise ReplayError("the .viser recording is cut short")
    length = int.from_bytes(payload[:8], "little")
    try:
        head = msgspec.msgpack.decode(payload[8 : 8 + length])
        lengths = [int(n) for n in head["binaryBufferLengths"]]
        messages = tuple((float(t), dict(m)) for t, m in head["messages"])
        duration, version = float(head["durationSeconds"]), str(head["viserVersion"])
    except (msgspec.DecodeError, KeyError, TypeError, ValueError) as error:
        raise ReplayError(f"the .viser recording's index is unreadable: {error}") from None
    buffers, offset = [], 8 + length
    for n in lengths:
        offset += (8 - offset % 8) % 8
        if offset + n > len(payload):
            raise ReplayError("the .viser recording's binary data is cut short")
        buffers.append(payload[offset : offset + n])
        offset += n
    return ViserRecording(duration, version, messages, tuple(buffers))
