"""Fixtures of the planner tests: dircon_biped, its planar model, and a copy of its pinocchio
model with frames at the heel and toe mid-points of each sole (the planner's contact points,
built here independently). Modules with their own `robot` fixture override this one."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from app.core.collocation.dircon import PlanarModel
from app.core.robot.loading import load_robot


@pytest.fixture(scope="module")
def robot():
    return load_robot("dircon_biped")


@pytest.fixture(scope="module")
def planar(robot):
    return PlanarModel(robot)


@pytest.fixture(scope="module")
def full(robot):
    """(model, data, frame ids of left heel, left toe, right heel, right toe)."""
    model = robot.model.copy()
    frame_ids = []
    for foot in robot.feet:
        sole = model.frames[robot.link_frame_ids[foot.link]]
        corners = foot.sole_corners_m
        rear = corners[np.isclose(corners[:, 0], corners[:, 0].min())].mean(axis=0)
        front = corners[np.isclose(corners[:, 0], corners[:, 0].max())].mean(axis=0)
        for name, point in (("heel", rear), ("toe", front)):
            frame = pin.Frame(
                f"{foot.side}_{name}",
                sole.parentJoint,
                sole.placement * pin.SE3(np.eye(3), point),
                pin.FrameType.OP_FRAME,
            )
            frame_ids.append(model.addFrame(frame))
    return model, model.createData(), frame_ids
