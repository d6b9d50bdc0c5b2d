"""A sweep with simulate = true: each point's walk, torques, commands and MuJoCo run on a Dask
worker give what the same stages give run one after the other here, and servo stiffness changes
the fall verdict the way physics says."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from app.core.collocation.gait_problem import GaitProblem
from app.core.dynamics.wbc import torque_feedforward
from app.core.errors import StudioError
from app.core.robot.loading import load_robot
from app.core.servo.commands import servo_commands
from app.core.servo.compensation import disabled_params
from app.core.servo.model import ServoModel, joint_angles
from app.core.servo.presets import uniform_preset
from app.core.simulation.drive import plan_drive_torque_Nm
from app.core.simulation.run import simulate
from app.core.sweeps.results import SIMULATION_COLUMNS, columns, results_csv
from app.core.sweeps.sampling import sweep_points
from app.core.sweeps.spec import SweepSpec
from app.core.walking.walk import build_walk
from app.sweep_engine import SweepEngine

STIFF, COMPLIANT = 0.0, 5.0
"""Servo compliance of the pair [°/(N·m)]: rigid, and 3.5 × the paper's identifiable servos."""
DATA = {
    "sampling": "grid",
    "start": "cold",
    "gait": {"knots": 14},
    "simulate": True,
    "walk_steps": 1,
    "servo": {"dead_band_deg": 0.0},
    "pareto": {"sr": "min", "max_torso_error_deg": "min"},
    "parameter": [
        {
            "kind": "servo",
            "name": "compliance_deg_per_Nm",
            "min": STIFF,
            "max": COMPLIANT,
            "levels": 2,
        },
        {"kind": "servo", "name": "compensation", "min": 0, "max": 1, "levels": 2},
    ],
}


@pytest.fixture(scope="module")
def swept():
    spec = SweepSpec.from_mapping(DATA)
    points = sweep_points(spec)
    with SweepEngine(n_workers=2) as engine:
        results = {r.index: r for r in engine.start(points).results()}
    return spec, points, results


@pytest.fixture(scope="module")
def by_hand(swept):
    """The same points through the stages one after the other, as `plan --steps`, `feedforward`,
    `compensate` and `simulate` chain them."""
    _spec, points, _ = swept
    robot = load_robot("dircon_biped")
    problem = GaitProblem(robot, knots=14, baseline=False)
    out = {}
    for point in points:
        gait = problem.solve(point.settings, cold=True)
        assert gait.converged
        walk = build_walk(problem.model, gait, steps=1)
        tau = torque_feedforward(robot, walk.trajectory).tau_Nm
        k, compensated = point.values
        # compensation on: a calibrated servo, k of eq 7 = its true compliance
        params = uniform_preset(robot, k) if compensated else disabled_params(robot.joint_names)
        legs = uniform_preset(robot).enabled
        servo = ServoModel(robot.joint_names, np.where(legs, k, 0.0), np.zeros(robot.n_actuated))
        # on the servos' drive torque τ + D·q̇ + J·q̈ (`simulate --drive-torque`, the studio's default)
        drive = plan_drive_torque_Nm(robot, walk.trajectory, tau, servo)
        commands = servo_commands(robot, walk.trajectory, drive, params)
        if not compensated:
            assert np.array_equal(commands.q_cmd_rad, joint_angles(robot, walk.trajectory.q))
        # a servo clips its goal to its limits (the URDF's, as pinocchio reads them)
        lower, upper = urdf_limits(robot)
        q_cmd = commands.q_cmd_rad
        past = (q_cmd < lower) | (q_cmd > upper)
        try:
            sim = simulate(
                robot, walk.trajectory, np.minimum(np.maximum(q_cmd, lower), upper), servo
            )
        except StudioError as error:
            sim = error
        out[point.index] = (robot, walk, tau, sim, past)
    return out


def urdf_limits(robot) -> tuple[np.ndarray, np.ndarray]:
    """The actuated joints' limits as pinocchio reads them from the URDF (not the studio's)."""
    model = pin.buildModelFromUrdf(str(robot.source))
    q_index = [model.joints[model.getJointId(name)].idx_q for name in robot.joint_names]
    return model.lowerPositionLimit[q_index], model.upperPositionLimit[q_index]


def test_simulation_metrics_equal_the_stages_run_one_by_one(swept, by_hand):
    _spec, points, results = swept
    assert sorted(results) == [0, 1, 2, 3]
    refused = 0
    for point in points:
        result = results[point.index]
        robot, walk, _tau, sim, _past = by_hand[point.index]
        assert result.solved
        if isinstance(sim, StudioError):  # a stage refused: the sweep says why, metrics NaN
            assert result.sim_status == f"not simulated: {sim}"
            assert math.isnan(result.fell) and math.isnan(result.max_torso_error_deg)
            refused += 1
            continue
        assert result.fell == (1.0 if sim.fell else 0.0)
        assert result.sim_status == sim.verdict()
        if sim.fell:
            assert result.fall_time_s == pytest.approx(sim.fall_time_s, abs=1e-9)
        else:
            assert math.isnan(result.fall_time_s)
        summary = sim.summary()
        torso = max(summary["max_roll_error_deg"], summary["max_pitch_error_deg"])
        assert result.max_torso_error_deg == pytest.approx(torso, rel=1e-6, abs=1e-9)
        assert result.rms_joint_error_deg == pytest.approx(sim.rms_joint_error_deg, rel=1e-6)
        shown = sim.t <= sim.simulated_until_s
        q_plan = joint_angles(robot, walk.trajectory.q)
        tracking = np.degrees(np.abs(sim.q_joints_rad[shown] - q_plan[shown]).max())
        assert result.max_tracking_error_deg == pytest.approx(tracking, rel=1e-6, abs=1e-9)
        assert result.sim_s > 0
    assert refused == 0
    # k = 5 °/(N·m) compensated asks the hips past their limits: clipped to them and simulated
    # (the metrics above equal the clipped commands' run), the point's notes say so
    for point in points:
        past = by_hand[point.index][4]
        if not past.any():
            assert "clipped" not in results[point.index].sim_notes
            continue
        assert point.values == (COMPLIANT, 1.0)
        k, j = np.argwhere(past)[0]  # the first command past a limit, in time then joint order
        robot, walk = by_hand[point.index][:2]
        assert "hip" in robot.joint_names[j]
        notes = results[point.index].sim_notes
        assert f"{int(past.sum())} compensated command(s) past the joint limits" in notes
        assert f"first {robot.joint_names[j]} at t = {walk.trajectory.t[k]:.2f} s" in notes
    assert by_hand[3][4].any()


def test_stiff_servos_walk_and_very_compliant_ones_sag_and_fall(swept, by_hand):
    _spec, points, results = swept
    plain = [p for p in points if p.values[1] == 0.0]  # uncompensated
    stiff, compliant = (results[p.index] for p in plain)
    assert [p.values[0] for p in plain] == [STIFF, COMPLIANT]
    # Independently of the simulation: a servo of compliance k under torque τ lags k·τ behind
    # its command (eq 7). Rigid servos follow the plan; at k = 5 °/(N·m) the stance knee's
    # torque alone sags it by tens of degrees, which no balance survives uncorrected.
    robot, _walk, tau, _sim, _past = by_hand[plain[1].index]
    knees = [i for i, name in enumerate(robot.joint_names) if "knee" in name]
    sag_deg = COMPLIANT * np.abs(tau[:, knees]).max()
    assert sag_deg > 20.0
    # (the verdict also says how far it went: dircon_biped's 1-step walk on rigid servos
    # shuffles, its swing foot landing short; a walk, not a fall)
    assert stiff.fell == 0.0 and not stiff.sim_status.startswith("falls")
    assert compliant.fell == 1.0
    assert compliant.rms_joint_error_deg > stiff.rms_joint_error_deg
    assert compliant.fall_time_s < by_hand[plain[1].index][1].trajectory.duration


def test_the_results_table_has_the_simulation_columns(swept):
    spec, _points, results = swept
    header = results_csv(spec, list(results.values())).splitlines()[0].split(",")
    assert header[len(spec.parameters) : -1] == list(columns(spec))
    assert set(SIMULATION_COLUMNS) <= set(header)
    plain = SweepSpec.from_mapping(
        {"parameter": [{"kind": "gait", "name": "H_s", "min": 0.6, "max": 0.8}]}
    )
    assert not set(SIMULATION_COLUMNS) & set(columns(plain))
