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
    "without": ((220, 50, 50), "predicted actual, no compensation"),
    "with": ((240, 150, 20), "predicted actual, compensated"),
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
        self._visible = dict.fromkeys(GHOSTS, True)
        self._poses: dict[str, np.ndarray] = {}

    def update(self, configurations: dict[str, np.ndarray]) -> None:
        """Place each ghost at its configuration (pinocchio layout)."""
        for name, q in configurations.items():
            self._poses[name] = q
            if self._visible[name]:
                self._views[name].update(q)

    def set_visible(self, name: str, visible: bool) -> None:
        self._visible[name] = visible
        self._views[name].set_visible(visual=visible, collision=False, frames=False, com=False)
        if visible and name in self._poses:
            self._views[name].update(self._poses[name])

    def remove(self) -> None:
        for view in self._views.values():
            view.remove()


def legend_markdown() -> str:
    return "  \n".join(
        f'<span style="color: rgb{rgb}">■</span> {text}' for rgb, text in GHOSTS.values()
    )
