"""Traces of a trajectory: the feet's and the CoM's paths as polylines, and a time marker."""

from __future__ import annotations

import numpy as np
import viser

from app.views.roots import NodeLayer

COLOURS = {"left": (30, 110, 220), "right": (220, 60, 60), "com": (230, 40, 90)}


class TracesView(NodeLayer):
    def __init__(
        self, server: viser.ViserServer, paths: dict[str, np.ndarray], root: str = "/traces"
    ) -> None:
        self._nodes = []
        for name, points in paths.items():
            segments = np.stack([points[:-1], points[1:]], axis=1).astype(np.float32)
            self._nodes.append(
                server.scene.add_line_segments(
                    f"{root}/{name}",
                    segments,
                    COLOURS.get(name, (90, 90, 90)),
                    thickness=4.0,
                    thickness_units="screen",
                )
            )
