"""A real studio on a free local port, for the server-side tests."""

from __future__ import annotations

import socket
from pathlib import Path

from app.config import StudioConfig
from app.studio import Studio


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def start_studio(data_dir: Path) -> Studio:
    """A studio on the default robot, serving on a free port of 127.0.0.1."""
    return Studio(StudioConfig(port=free_port(), data_dir=data_dir))
