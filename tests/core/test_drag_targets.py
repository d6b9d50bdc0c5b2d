"""Drag targets from a client are checked: a NaN, a zero quaternion or a far-away target is
a StudioError (a notification), never an exception in the drag handler."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from app.core.errors import StudioError
from app.core.posing.drag import DragTargetError, Posing, drag_target
from app.core.robot.loading import load_robot


@pytest.mark.parametrize("scale", [2.0, 1e-6, 1e308])
def test_target_matches_pinocchio_quaternion(scale: float) -> None:
    quat = np.array([1.0, 0.0, 0.0, 1.0]) * scale  # not normalised: 90° about z
    T = drag_target(np.array([0.1, 0.2, 0.3]), quat)
    expected = pin.SE3(
        pin.Quaternion(np.array([0.0, 0.0, 1.0, 1.0]) / np.sqrt(2)), np.array([0.1, 0.2, 0.3])
    )
    np.testing.assert_allclose(T, expected.homogeneous, atol=1e-12)


@pytest.mark.parametrize(
    "position, quat, message",
    [
        ([np.nan, 0, 0], [1, 0, 0, 0], "not finite"),
        ([0, 0, 0], [0, 0, 0, 0], "zero quaternion"),
        ([0, 0, 0], [np.inf, 0, 0, 0], "not finite"),
        ([1e308, 0, 0], [1, 0, 0, 0], "at most 100 m"),
        ([0, 0], [1, 0, 0, 0], "3 position"),
    ],
)
def test_bad_targets_are_studio_errors(position, quat, message) -> None:
    with pytest.raises(StudioError, match=message):
        drag_target(np.array(position, dtype=float), np.array(quat, dtype=float))


def test_drag_refuses_a_non_finite_placement() -> None:
    robot = load_robot("servo_biped")
    posing = Posing(robot)
    T = np.eye(4)
    T[0, 3] = np.nan
    with pytest.raises(DragTargetError):
        posing.drag(robot.q_neutral, "left", T)
    with pytest.raises(DragTargetError, match="no handle named"):
        posing.drag(robot.q_neutral, "head", np.eye(4))
