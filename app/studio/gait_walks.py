"""The walk of a planned gait on screen, and its footprints (they belong to the walk: gone when
another motion is shown)."""

from __future__ import annotations

import viser

from app.core.robot.model import RobotModel
from app.core.walking.walk import Walk
from app.studio.state import Motion
from app.views.footprints_view import FootprintsView, sole_size_m
from app.views.roots import AlternatingRoot


class ShownWalk:
    """The walk last sent to playback and its footprints overlay."""

    def __init__(self, server: viser.ViserServer) -> None:
        self._server = server
        self._roots = AlternatingRoot("/footprints")
        self.walk: Walk | None = None
        """The walk last sent to playback."""
        self.footprints: FootprintsView | None = None

    def show_footprints(self, robot: RobotModel, walk: Walk) -> None:
        """Draw `walk`'s footprints (replacing the ones drawn)."""
        if self.footprints is not None:
            self.footprints.remove()
        prints = [(f.side, f.x_m, f.y_m) for f in walk.footprints]
        self.footprints = FootprintsView(
            self._server, prints, sole_size_m(robot.feet[0].sole_corners_m), self._roots.next()
        )

    def on_motion(self, motion: Motion | None) -> None:
        """Footprints belong to the walk: gone when another motion is shown."""
        walk = self.walk
        if self.footprints is not None and (
            motion is None or walk is None or motion.trajectory is not walk.trajectory
        ):
            self.footprints.remove()
            self.footprints, self.walk = None, None
