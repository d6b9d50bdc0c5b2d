"""Ghost robots: the same robot drawn several times, each in one translucent colour, for
comparing motions (planned, commanded, predicted) sample by sample."""

from __future__ import annotations

import numpy as np
import viser

from app.core.robot.model import RobotModel
from app.views.robot_view import RobotView

GHOSTS = {
    "planned": ((60, 120, 230), "planned motion"),
    "command": ((40, 170, 80), "compensated servo command"),
    "without": ((220, 50, 50), "quick estimate, no compensation"),
    "with": ((240, 150, 20), "quick estimate, compensated"),
    "sim_without": ((150, 60, 200), "simulated (MuJoCo), no compensation"),
    "sim_with": ((20, 170, 170), "simulated (MuJoCo), compensated"),
}
"""name -> (colour, legend text)."""
OPACITY = 0.4


class GhostsView:
    def __init__(self, server: viser.ViserServer, robot: RobotModel, root: str = "/ghosts") -> None:
        with server.atomic():
            self._views = {
                name: RobotView(
                    server,
                    robot,
                    root=f"{root}/{name}",
                    tint_rgb=rgb,
                    opacity=OPACITY,
                    with_collision=False,
                )
                for name, (rgb, _) in GHOSTS.items()
            }
            for view in self._views.values():  # nothing drawn before a ghost has a pose
                view.set_visible(visual=False, collision=False, frames=False, com=False)
        self._wanted = dict.fromkeys(GHOSTS, True)
        """What the user's toggles ask for."""
        self._poses: dict[str, np.ndarray] = {}

    def update(self, configurations: dict[str, np.ndarray]) -> None:
        """Place each ghost at its configuration (pinocchio layout)."""
        for name, q in configurations.items():
            first = name not in self._poses
            self._poses[name] = q
            if self._wanted[name]:
                if first:
                    self._show(name, True)
                self._views[name].update(q)

    def forget(self, name: str) -> None:
        """Hide a ghost until it gets a pose again (e.g. a simulation that went stale)."""
        if self._poses.pop(name, None) is not None:
            self._show(name, False)

    def set_visible(self, name: str, visible: bool) -> None:
        self._wanted[name] = visible
        self._show(name, visible and name in self._poses)
        if visible and name in self._poses:
            self._views[name].update(self._poses[name])

    def _show(self, name: str, visible: bool) -> None:
        self._views[name].set_visible(visual=visible, collision=False, frames=False, com=False)

    def remove(self) -> None:
        for view in self._views.values():
            view.remove()


def legend_markdown() -> str:
    return "  \n".join(
        f'<span style="color: rgb{rgb}">■</span> {text}' for rgb, text in GHOSTS.values()
    )
