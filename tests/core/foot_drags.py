"""A foot dragged as the gizmo drags it, for the posing tests: frame placements by pinocchio and
the left foot pulled straight up in small events."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from app.core.posing.drag import Posing
from app.core.posing.ik import IkResult
from app.core.robot.model import RobotModel


def placement(bot: RobotModel, q: np.ndarray, link: str) -> pin.SE3:
    """World placement of `link` at `q`, by pinocchio's forward kinematics."""
    data = bot.model.createData()
    pin.framesForwardKinematics(bot.model, data, q)
    return data.oMf[bot.model.getFrameId(link, pin.BODY)].copy()


def drag_up(bot: RobotModel, lift_m: float, events: int = 30) -> tuple[IkResult, np.ndarray]:
    """The left foot dragged straight up by `lift_m` from standing in `events` gizmo events:
    the last drag's result and its target (4 × 4)."""
    posing = Posing(bot)
    q = bot.q_neutral.copy()
    start = placement(bot, q, bot.foot("left").link).homogeneous
    for k in range(1, events + 1):
        target = start.copy()
        target[2, 3] += lift_m * k / events
        result = posing.drag(q, "left", target)
        q = result.q
    return result, target
