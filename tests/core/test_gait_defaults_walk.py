"""The default walk reads as walking (issue 23 defect 9): for servo_biped and a third-party
robot (Roban S14), the default settings step at least a quarter of the leg, the gait solves
with them, and the walk built from it really advances by that step.

The leg length is measured here with pinocchio from the URDF alone (each leg's top joint above
the lowest sole corner with straight legs, less the ready pose's 5 % crouch), and the walk's
footholds from pinocchio's sole placements of the walk's own configurations, not from the
settings or the planner's readouts.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from app.core.collocation.defaults import FROUDE, default_settings
from app.core.collocation.dircon import GaitProblem
from app.core.robot.loading import load_robot
from app.core.walking.walk import build_walk
from tests.conftest import ROBAN_URDF

STEPS = 4
FOOTHOLD_TOL_M = 1e-3


@pytest.fixture(scope="module", params=["servo_biped", "roban_s14"])
def walked(request):
    robot = load_robot("servo_biped" if request.param == "servo_biped" else ROBAN_URDF)
    settings = default_settings(robot)
    problem = GaitProblem(robot)
    result = problem.solve(settings)
    assert result.converged, f"{result.status}: {result.blame}"
    return robot, settings, result, build_walk(problem.model, result, steps=STEPS)


def leg_length(robot) -> float:
    """Hip-to-sole height in the ready pose [m], by pinocchio from the URDF."""
    model, data = robot.model, robot.model.createData()
    q = pin.neutral(model)
    pin.framesForwardKinematics(model, data, q)
    soles = [
        data.oMf[robot.link_frame_ids[f.link]].act(c)[2]
        for f in robot.feet
        for c in f.sole_corners_m
    ]
    tops = []
    for foot in robot.feet:
        joint = model.frames[robot.link_frame_ids[foot.link]].parentJoint
        while model.parents[joint] > 1:  # up to the joint just below the free-flyer
            joint = model.parents[joint]
        tops.append(data.oMi[joint].translation[2])
    return 0.95 * (float(np.mean(tops)) - min(soles))


def footholds(robot, trajectory) -> list[tuple[float, int, float]]:
    """(start time, side, sole-centre x) of every contact phase of each foot, by pinocchio at
    the phase's first sample (where the foot is put down), in order of landing."""
    data = robot.model.createData()
    phases = []
    for side in (0, 1):
        contact = trajectory.contacts[:, side].astype(int)
        edges = np.flatnonzero(np.diff(np.concatenate([[0], contact, [0]])))
        for k in edges[::2]:  # where each contact phase starts: the foot is put down
            pin.framesForwardKinematics(robot.model, data, trajectory.q[k])
            foot = robot.feet[side]
            centre = data.oMf[robot.link_frame_ids[foot.link]].act(foot.sole_corners_m.mean(0))
            phases.append((float(trajectory.t[k]), side, float(centre[0])))
    return sorted(phases)


def test_default_step_is_at_least_a_quarter_of_the_leg(walked):
    robot, settings, _, _ = walked
    leg = leg_length(robot)
    step = settings.step_length_m / 2.0  # the advance covers two steps
    assert step >= 0.25 * leg
    # The period from the documented Froude scaling: v = 2 step / H, Fr = v² / (g L).
    froude = (settings.step_length_m / settings.H_s) ** 2 / (9.81 * leg)
    assert froude == pytest.approx(FROUDE, rel=0.02)
    assert 0.3 < settings.H_s < 1.0  # a step or two per second: a walk, not a shuffle


def test_the_walk_advances_by_the_default_step(walked):
    robot, settings, _, walk = walked
    phases = footholds(robot, walk.trajectory)
    xs = np.array([x for _, _, x in phases])
    # From the first stance to the final one, each landing puts its foot one step ahead of
    # the other foot's last foothold: the steps of the walk, measured.
    by_side: dict[int, float] = {}
    advances = []
    for _, side, x in phases:
        other = by_side.get(1 - side)
        if other is not None and side in by_side:
            advances.append(x - other)
        by_side[side] = x
    step = settings.step_length_m / 2.0
    assert len(advances) >= STEPS - 1
    np.testing.assert_allclose(advances, step, atol=FOOTHOLD_TOL_M)
    assert xs.max() - xs.min() >= (STEPS - 1) * step - FOOTHOLD_TOL_M
    assert step >= 0.25 * leg_length(robot)
