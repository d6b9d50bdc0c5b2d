"""Serve a replay folder on this machine (`biped-studio replay open`): a static file server for
one folder, that never answers with a file outside it, even through a link made after start."""

from __future__ import annotations

import functools
import http.server
import os
from pathlib import Path

from app.core.replay.folder import check_replay_folder


class ReplayRequestHandler(http.server.SimpleHTTPRequestHandler):
    """Static files of one folder; a path that resolves outside it is a 404; no listings."""

    def send_head(self):
        """404 for a path that resolves outside the folder (`..`, or a link made later)."""
        root = Path(self.directory).resolve()
        resolved = Path(self.translate_path(self.path)).resolve()
        if resolved != root and root not in resolved.parents:
            self.send_error(404, "not in the replay folder")
            return None
        return super().send_head()

    def list_directory(self, path: str | os.PathLike[str]) -> None:
        self.send_error(404, "no listing")
        return None

    def log_message(self, format: str, *args: object) -> None:  # quiet: the link is the output
        pass


def replay_http_server(folder: Path, port: int) -> http.server.ThreadingHTTPServer:
    """A server for the replay folder on 127.0.0.1:`port` (0: any free port), not yet serving.
    ReplayError if the folder is not a replay; OSError if the port is taken."""
    root = check_replay_folder(folder)
    handler = functools.partial(ReplayRequestHandler, directory=str(root))
    return http.server.ThreadingHTTPServer(("127.0.0.1", port), handler)
