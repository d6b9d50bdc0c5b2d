"""A sweep over servo parts with the simulation: each point runs its catalogue servo and kp on
the legs (the part's motor law, its electrical energy), and the physics orders the points the
way the motor law's closed-form stiffness K = kt·vin·error_gain·kp/R says: a higher kp or a
stiffer servo tracks the plan better. The results table names each point's servo."""

from __future__ import annotations

import math

import numpy as np
import pytest

from app.core.collocation.planar_model import PlanarModel
from app.core.robot.loading import load_robot
from app.core.servo.catalogue import load_catalogue
from app.core.servo.presets import uniform_preset
from app.core.sweeps.evaluate import ProblemCache, evaluate_point, solve_point
from app.core.sweeps.results import results_csv
from app.core.sweeps.sampling import sweep_points
from app.core.sweeps.servo_metrics import walk_and_simulate
from app.core.sweeps.spec import SweepSpec

SERVOS, KP = ("mx64", "mx106"), (4.0, 64.0)
DATA = {
    "sampling": "grid",
    "gait": {"knots": 14},
    "simulate": True,
    "walk_steps": 1,
    "servo": {"dead_band_deg": 0.0, "compensation": 0},  # the plan as it is: the sag shows
    "pareto": {"sr": "min", "rms_joint_error_deg": "min"},
    "parameter": [
        {"kind": "part", "name": "servo", "choices": list(SERVOS)},
        {"kind": "part", "name": "kp", "min": KP[0], "max": KP[1], "levels": 2},
    ],
}


def stiffness_Nm_per_rad(key: str, kp: float) -> float:
    """K = kt·vin·error_gain·kp/R from the record's m1 fit and firmware (issue 27)."""
    record = load_catalogue()[key]
    motor, firmware = record.fit("m1").motor, record.firmware
    return motor.kt_Nm_per_A * firmware.vin_V * firmware.error_gain * kp / motor.R_ohm


@pytest.fixture(scope="module")
def swept():
    spec = SweepSpec.from_mapping(DATA)
    points = sweep_points(spec)
    cache = ProblemCache()
    results = {p.index: evaluate_point(p, cache) for p in points}
    return spec, points, results, cache


def test_each_point_runs_its_part_and_kp(swept):
    _spec, points, results, cache = swept
    by_part = {(p.simulation.part.servo, p.simulation.part.kp): p for p in points}
    assert set(by_part) == {(s, kp) for s in SERVOS for kp in KP}
    point = by_part[("mx106", 64.0)]
    robot = load_robot("dircon_biped")
    gait = solve_point(point, cache)
    _walk, _ff, _commands, servo, sim = walk_and_simulate(
        PlanarModel(robot), gait, point.simulation
    )
    legs = uniform_preset(robot).enabled
    # the part's law ran on the legs (electrical energy), the other joints draw nothing
    assert sim.energy is not None
    assert np.all(sim.energy.electrical_J[legs] > 0.0)
    assert np.all(sim.energy.electrical_J[~legs] == 0.0)
    expected = math.degrees(1.0 / stiffness_Nm_per_rad("mx106", 64.0))
    np.testing.assert_allclose(servo.compliance_deg_per_Nm[legs], expected, rtol=1e-12)
    result = results[point.index]
    assert result.rms_joint_error_deg == pytest.approx(sim.rms_joint_error_deg, rel=1e-9)


def test_stiffer_parts_track_the_plan_better(swept):
    _spec, points, results, _ = swept
    rms = {
        (p.simulation.part.servo, p.simulation.part.kp): results[p.index].rms_joint_error_deg
        for p in points
    }
    assert all(math.isfinite(v) for v in rms.values()), rms
    for servo in SERVOS:  # K ∝ kp: 16 × stiffer at kp 64 than at kp 4
        assert rms[(servo, KP[1])] < rms[(servo, KP[0])]
    stiffer, softer = sorted(SERVOS, key=lambda s: -stiffness_Nm_per_rad(s, KP[1]))
    assert stiffness_Nm_per_rad(stiffer, KP[1]) > 1.2 * stiffness_Nm_per_rad(softer, KP[1])
    assert rms[(stiffer, KP[1])] < rms[(softer, KP[1])]


def test_the_results_table_names_each_points_servo(swept):
    spec, points, results, _ = swept
    lines = results_csv(spec, list(results.values())).splitlines()
    assert lines[0].startswith("servo,kp,")
    for point, line in zip(points, lines[1:], strict=True):
        servo, kp = line.split(",")[:2]
        assert (servo, float(kp)) == (point.simulation.part.servo, point.simulation.part.kp)


def test_the_parts_axes_follow_from_the_catalogue_and_the_envelopes_closed_form(swept):
    """servo_mass_kg is the catalogue mass on every leg joint; servo_margin is recomputed here
    from the motor law's closed forms (stall τ_s = kt·vin·max_pwm/R, no-load ω_0 =
    vin·max_pwm/kt, the line τ = τ_s − (τ_s/ω_0)·ω, the current limit kt·I_lim) and the RMS
    torque against the continuous rating, over the point's own walk and torques."""
    from app.core.dynamics.peaks import over_speed_samples
    from app.core.servo.sizing import CONTINUOUS_FRACTION_OF_STALL

    _spec, points, results, cache = swept
    robot = load_robot("dircon_biped")
    legs = np.flatnonzero(uniform_preset(robot).enabled)
    for point in points:
        key = point.simulation.part.servo
        record = load_catalogue()[key]
        result = results[point.index]
        assert result.servo_mass_kg == pytest.approx(len(legs) * record.mass_kg, rel=1e-12)
        if record.price is None:  # the MX-64's list price was not found
            assert math.isnan(result.servo_cost)
        else:  # the MX-106's: the catalogue's published price on every leg joint
            assert result.servo_cost == pytest.approx(len(legs) * record.price, rel=1e-12)
        walk, ff, _commands, _servo, sim = walk_and_simulate(
            PlanarModel(robot), solve_point(point, cache), point.simulation
        )
        assert result.electrical_energy_J == pytest.approx(
            float(np.sum(sim.energy.electrical_J[legs])), rel=1e-9
        )
        motor, firmware = record.fit("m1").motor, record.firmware
        kt, r = motor.kt_Nm_per_A, motor.R_ohm
        stall = kt * firmware.vin_V * firmware.max_pwm / r
        no_load = firmware.vin_V * firmware.max_pwm / kt
        limit = math.inf if firmware.current_limit_A is None else kt * firmware.current_limit_A
        rating = record.continuous_torque_Nm or CONTINUOUS_FRACTION_OF_STALL * stall
        skipped = {k for k, s in enumerate(ff.status) if s != "solved"}
        skipped |= set(over_speed_samples(robot, walk.trajectory))
        keep = [k for k in range(walk.trajectory.n_samples) if k not in skipped]
        margins = []
        for j in legs:
            w = walk.trajectory.v[keep, robot.joints[j].idx_v]
            tau = ff.tau_Nm[keep, j]
            scale = [
                min(
                    stall / abs(t + stall / no_load * s) if t + stall / no_load * s else math.inf,
                    limit / abs(t) if t else math.inf,
                )
                for s, t in zip(w, tau, strict=True)
            ]
            rms = math.sqrt(float(np.mean(tau**2)))
            margins.append(min(min(scale) - 1.0, rating / rms - 1.0))
        assert result.servo_margin == pytest.approx(min(margins), rel=1e-9), (key, point.index)
