"""The ideal servo's electrical energy over servo_biped's planned walk (issue 26, Table 4 like
for like): the post hoc reconstruction from the 100 Hz records against MuJoCo's own torques.

Reference: the same commands held over samples one physics tick apart (each repeated ten
times: the same physics), whose records are MuJoCo's per tick: the actuators' qfrc_actuator
after each step (`tau_Nm`) less the joint damping D·q̇, times the step's displacement of
MuJoCo's qpos (`q_joints_rad`) — the step integrator's work, no reconstruction.
"""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from tests.test_cli import run

TICKS = 10  # the walk's 10 ms samples over the 1 ms physics step


@pytest.fixture(scope="module")
def walk(tmp_path_factory):
    out = tmp_path_factory.mktemp("walk") / "walk.csv"
    result = run("plan", "--robot", "servo_biped", "--steps", "6", "--out", str(out))
    assert result.returncode == 0, result.stderr
    return out


@pytest.fixture(scope="module")
def rollouts(walk):
    from app.cli.common import coefficients_from_args
    from app.core.dynamics.wbc import torque_feedforward
    from app.core.motions.csv_files import read_trajectory_csv
    from app.core.robot.loading import load_robot
    from app.core.servo.compensation import compensated_command
    from app.core.servo.model import joint_angles
    from app.core.simulation.files import sized_servos
    from app.core.simulation.run import simulate
    from app.core.simulation.servo_law import robot_servo_law

    robot = load_robot("servo_biped")
    traj = read_trajectory_csv(walk, robot)
    servo = sized_servos(robot)
    tau = torque_feedforward(robot, traj).tau_Nm
    params = coefficients_from_args(robot, "uniform", False, None)
    cmd = compensated_command(joint_angles(robot, traj.q), tau, params)
    coarse = simulate(robot, traj, cmd, servo)

    def rep(x):
        return np.repeat(x, TICKS, axis=0)

    fine_traj = dataclasses.replace(
        traj,
        t=np.arange(len(traj.t) * TICKS) * traj.dt / TICKS,
        q=rep(traj.q), v=rep(traj.v), a=rep(traj.a), contacts=rep(traj.contacts),
    )  # fmt: skip
    fine = simulate(robot, fine_traj, rep(cmd), servo)
    assert not coarse.fell and not fine.fell
    return robot, robot_servo_law(robot, servo), coarse, fine


def test_the_mechanical_part_is_mujocos_own_work(rollouts):
    from app.core.simulation.ideal_energy import default_motor, run_ideal_energy

    robot, law, coarse, fine = rollouts
    dofs = np.array([joint.idx_v for joint in robot.joints])
    motor = default_motor(law.effort_Nm)
    # MuJoCo's per-tick work on the fine rollout (module docstring)
    torque = fine.tau_Nm[:-1] - law.damping_Nms_per_rad * fine.v[1:, dofs]
    power = torque * np.diff(fine.q_joints_rad, axis=0)
    work, positive = float(power.sum()), float(np.maximum(power, 0.0).sum())
    assert positive > 5.0  # the walk does work: the comparison means something
    # the same run, reconstructed by the law at each tick: MuJoCo's actuators to 1 %
    same = run_ideal_energy(fine, law, dofs, motor)
    assert same.mechanical_J.sum() == pytest.approx(work, rel=0.01)
    # the 100 Hz run, reconstructed between its samples, against MuJoCo's per-tick work
    energy = run_ideal_energy(coarse, law, dofs, motor)
    assert energy.positive_work_J.sum() == pytest.approx(positive, rel=0.01)
    assert energy.mechanical_J.sum() == pytest.approx(work, rel=0.03)  # a net of ±: looser
    # and the electrical energy (I²R from MuJoCo's torque, no regeneration credit)
    joule = (torque / motor.kt_Nm_per_A) ** 2 * motor.R_ohm * (fine.t[1] - fine.t[0])
    drawn = np.maximum(power + joule, 0.0).sum()
    assert energy.electrical_J.sum() == pytest.approx(drawn, rel=0.02)


def test_simulate_reports_both_srs(walk):
    result = run(
        "simulate", str(walk), "--robot", "servo_biped", "--preset", "uniform", "--json"
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    assert "verdict" in report and "rms_joint_error_deg" in report  # the keys kept
    ideal = report["ideal_servo_energy"]
    total = ideal["total_electrical_J"]
    assert total == pytest.approx(sum(ideal["electrical_J"]))
    assert total >= ideal["total_mechanical_J"]  # I²R ≥ 0, braking not credited
    from app.core.robot.loading import load_robot

    weight = load_robot("servo_biped").mass_kg * 9.81
    assert ideal["sr_electrical"] == pytest.approx(total / (weight * ideal["distance_m"]))
    assert ideal["sr_planned"] is not None and "mx64" in ideal["motor"]
    text = run("simulate", str(walk), "--robot", "servo_biped", "--preset", "uniform")
    assert text.returncode == 0, text.stderr
    assert "electrical," in text.stdout and "planned work" in text.stdout
