"""Where each foot landed in a simulated walk against where the plan put it: a small white
sphere at each planned landing, a sphere in the run's colour where the simulated sole was
(`verdicts.Footstep`), and a line between them, under one root node."""

from __future__ import annotations

import numpy as np
import viser

from app.core.simulation.verdicts import Footstep
from app.views.roots import NodeLayer

RADIUS_M = 0.008
HEIGHT_M = 0.004
"""Markers sit this far above the floor [m] (above the planned footprints)."""
PLANNED_RGB = (245, 245, 245)


class LandingsView(NodeLayer):
    def __init__(
        self,
        server: viser.ViserServer,
        runs: list[tuple[tuple[int, int, int], tuple[Footstep, ...]]],
        root: str,
    ) -> None:
        """runs: (colour, footsteps) per simulated run."""
        self.root = root
        self._nodes: list[viser.SceneNodeHandle] = []
        planned_done: set[tuple[float, float]] = set()
        for r, (colour, footsteps) in enumerate(runs):
            segments = []
            for i, step in enumerate(footsteps):
                planned = (*step.planned_xy_m, HEIGHT_M)
                landed = (*step.simulated_xy_m, HEIGHT_M)
                if step.planned_xy_m not in planned_done:  # both runs share the plan
                    planned_done.add(step.planned_xy_m)
                    self._nodes.append(
                        server.scene.add_icosphere(
                            f"{root}/planned_{r}_{i}",
                            radius=RADIUS_M,
                            color=PLANNED_RGB,
                            position=planned,
                        )
                    )
                self._nodes.append(
                    server.scene.add_icosphere(
                        f"{root}/landed_{r}_{i}", radius=RADIUS_M, color=colour, position=landed
                    )
                )
                segments.append((planned, landed))
            if segments:
                self._nodes.append(
                    server.scene.add_line_segments(
                        f"{root}/errors_{r}",
                        points=np.array(segments, dtype=np.float32),
                        colors=colour,
                        thickness=0.003,
                    )
                )

    @property
    def count(self) -> int:
        """Scene nodes drawn."""
        return len(self._nodes)
