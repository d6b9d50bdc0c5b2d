"""Footprints of a planned walk on the floor: one flat rectangle per stance, left blue, right
red, under one root node."""

from __future__ import annotations

import numpy as np
import viser

from app.views.roots import NodeLayer

COLOURS = {"left": (30, 110, 220), "right": (220, 60, 60)}


class FootprintsView(NodeLayer):
    def __init__(
        self,
        server: viser.ViserServer,
        footprints: list[tuple[str, float, float]],
        sole_xy_m: tuple[float, float],
        root: str,
    ) -> None:
        """footprints: (side, x [m], y [m]) of each stance; sole_xy_m: (length, width) [m]."""
        length, width = sole_xy_m
        self._nodes = [
            server.scene.add_box(
                f"{root}/{i}",
                color=COLOURS.get(side, (90, 90, 90)),
                dimensions=(length, width, 0.002),
                position=(x, y, 0.001),
                opacity=0.45,
            )
            for i, (side, x, y) in enumerate(footprints)
        ]


def sole_size_m(corners_m: np.ndarray) -> tuple[float, float]:
    """(length along x, width along y) of a sole from its corners in the foot frame [m]."""
    extent = np.ptp(np.asarray(corners_m)[:, :2], axis=0)
    return float(extent[0]), float(extent[1])
