"""Fixtures of the planner tests: dircon_biped, its planar model, and a copy of its pinocchio
model with frames at the heel and toe mid-points of each sole (the planner's contact points,
built here independently), and a small solved gait. Modules with their own `robot` fixture
override this one. For the servo tests: servo_biped, its com_shift and one-leg stand motions. For
the paper's motions: servo_biped and Roban S14 by name."""

from __future__ import annotations

import pytest

from app.core.collocation.dircon import GaitProblem, GaitSettings, PlanarModel
from app.core.motions.library import run_motion
from app.core.robot.loading import load_robot
from tests.conftest import load_robots
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


@pytest.fixture(scope="module")
def one_leg(servo_biped):
    """servo_biped's one-leg stand (the paper's): both feet down, then the CoM over the left
    foot and the right foot lifted, held; a sample every 0.02 s."""
    return run_motion(servo_biped, "one_leg_stand", dt=0.02).trajectory


@pytest.fixture(scope="module")
def robots():
    """{name: RobotModel} of servo_biped and Roban S14, the robots the paper's motions are
    checked on; a module that checks more robots overrides this one."""
    return load_robots("servo_biped", "roban")
