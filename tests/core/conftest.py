"""Fixtures of the planner tests: dircon_biped, its planar model, and a copy of its pinocchio
model with frames at the heel and toe mid-points of each sole (the planner's contact points,
built here independently), and a small solved gait. Modules with their own `robot` fixture
override this one. For the servo tests: servo_biped and its com_shift motion."""

from __future__ import annotations

import pytest

from app.core.collocation.dircon import GaitProblem, GaitSettings, PlanarModel
from app.core.motions.library import run_motion
from app.core.robot.loading import load_robot
from tests.sole_frames import model_with_sole_edge_frames


@pytest.fixture(scope="module")
def robot():
    return load_robot("dircon_biped")


@pytest.fixture(scope="module")
def planar(robot):
    return PlanarModel(robot)


@pytest.fixture(scope="module")
def full(robot):
    """(model, data, frame ids of left heel, left toe, right heel, right toe)."""
    return model_with_sole_edge_frames(robot)


@pytest.fixture(scope="module")
def small(planar):
    """A 12-knot gait of the planar model, solved: (its GaitProblem, the result)."""
    problem = GaitProblem(planar, knots=12)
    result = problem.solve(GaitSettings(knots=12))
    assert result.converged, result.status
    return problem, result


@pytest.fixture(scope="module")
def servo_biped():
    return load_robot("servo_biped")


@pytest.fixture(scope="module")
def com_shift(servo_biped):
    """servo_biped's CoM shift onto one foot and back, both feet down."""
    return run_motion(servo_biped, "com_shift").trajectory
