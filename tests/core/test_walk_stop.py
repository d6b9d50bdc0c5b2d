"""servo_biped's default 6-step walk on its virtual servos, then held still for 1 s: it walks
the planned distance and is still standing after the stop (issue 26: "neither shuffles nor
falls at the stop").

Distance is MuJoCo's root body displacement (`SimulationResult.root_position_m`, read from
MuJoCo's qpos) against the plan's base; the fall test is the step loop's own (a link other
than the feet on the floor, torso tilt past 30°, pelvis below 60 %). The hold makes the run
see what happens after the motion ends, which a verdict judged over the motion alone cannot.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from app.core.collocation.defaults import robot_gait_defaults
from app.core.collocation.dircon import GaitProblem
from app.core.dynamics.wbc import torque_feedforward
from app.core.robot.loading import load_robot
from app.core.servo.compensation import CompensationParams, compensated_command, drive_torque_Nm
from app.core.servo.model import joint_angles
from app.core.simulation.files import default_servos
from app.core.simulation.mjcf import SimOptions
from app.core.simulation.run import simulate_commands
from app.core.simulation.servo_law import servo_law
from app.core.walking.walk import build_walk

HOLD_SAMPLES = 100  # 1 s at the walk's 10 ms


@pytest.fixture(scope="module")
def run():
    robot = load_robot("servo_biped")
    defaults = robot_gait_defaults(robot)
    problem = GaitProblem(robot, defaults.settings.knots, defaults.settings.baseline)
    walk = build_walk(problem.model, problem.solve(defaults.settings), steps=6)
    traj = walk.trajectory
    tau = torque_feedforward(robot, traj).tau_Nm
    n = HOLD_SAMPLES
    held = dataclasses.replace(
        traj,
        t=np.concatenate([traj.t, traj.t[-1] + traj.dt * np.arange(1, n + 1)]),
        q=np.concatenate([traj.q, np.repeat(traj.q[-1:], n, 0)]),
        v=np.concatenate([traj.v, np.zeros((n, traj.v.shape[1]))]),
        a=np.concatenate([traj.a, np.zeros((n, traj.a.shape[1]))]),
        contacts=np.concatenate([traj.contacts, np.repeat(traj.contacts[-1:], n, 0)]),
    )
    tau = np.concatenate([tau, np.repeat(tau[-1:], n, 0)])
    servo = default_servos(robot)
    law = servo_law(
        servo,
        robot.joint_names,
        [j.effort for j in robot.joints],
        [j.velocity for j in robot.joints],
    )
    columns = [j.idx_v for j in robot.joints]
    drive = drive_torque_Nm(
        tau,
        held.v[:, columns],
        held.a[:, columns],
        law.damping_Nms_per_rad,
        SimOptions().armature_kgm2,
    )
    k = servo.compliance_deg_per_Nm
    params = CompensationParams(robot.joint_names, k, np.zeros(len(k)), k > 0)
    q_cmd = compensated_command(joint_angles(robot, held.q), drive, params)
    result = simulate_commands(robot, held, {"eq 7, drive torque": q_cmd}, servo)
    return traj, result["eq 7, drive torque"]


def test_the_walk_covers_its_planned_distance(run):
    traj, result = run
    planned = traj.q[-1, 0] - traj.q[0, 0]
    end = traj.n_samples - 1  # the walk's last sample, before the hold
    covered = result.root_position_m[end, 0] - result.root_position_m[0, 0]
    assert planned > 0.45  # six 7.7 cm steps
    assert covered >= 0.9 * planned


def test_the_robot_still_stands_a_second_after_the_stop(run):
    _, result = run
    assert not result.fell, result.fall_reason
    # both soles on the floor at the end, carrying the weight between them
    assert np.all(result.contact_force_N[-1, :, 2] > 0.0)
