"""Servo parts as sweep parameters: the servo as a categorical parameter (each choice its own
stratum of the samples), kp as a discrete one, and the refusals of what cannot be swept."""

from __future__ import annotations

import math
from collections import Counter

import numpy as np
import pytest

from app.core.robot.loading import load_robot
from app.core.servo.catalogue import load_catalogue
from app.core.sweeps.robot_variants import SweepSpecError
from app.core.sweeps.sampling import sample_values, sweep_points
from app.core.sweeps.servo_metrics import servo_settings
from app.core.sweeps.spec import SweepSpec

CHOICES = ["mx64", "mx106", "xl330_m288"]


def data(**changes):
    base = {
        "sampling": "grid",
        "simulate": True,
        "walk_steps": 1,
        "parameter": [
            {"kind": "part", "name": "servo", "choices": CHOICES},
            {"kind": "part", "name": "kp", "min": 16, "max": 64, "levels": 3},
        ],
    }
    base.update(changes)
    return base


def test_a_grid_takes_every_servo_with_every_kp():
    spec = SweepSpec.from_mapping(data())
    assert spec.n_points == 9
    points = sweep_points(spec)
    pairs = {(p.simulation.part.servo, p.simulation.part.kp) for p in points}
    assert pairs == {(s, kp) for s in CHOICES for kp in (16.0, 40.0, 64.0)}
    for point in points:
        servo = spec.parameters[0]
        assert servo.shown(point.values[0]) == point.simulation.part.servo


@pytest.mark.parametrize("sampling", ["latin", "random"])
def test_random_and_latin_samples_pick_from_the_choices(sampling):
    spec = SweepSpec.from_mapping(data(sampling=sampling, samples=12, seed=3))
    values = sample_values(spec)
    assert set(values[:, 0]) <= {0.0, 1.0, 2.0}
    kp = values[:, 1]
    assert np.all((kp >= 16) & (kp <= 64)) and np.array_equal(kp, np.round(kp))
    if sampling == "latin":  # one stratum per choice: 12 samples, 4 of each
        assert Counter(values[:, 0].tolist()) == {0.0: 4, 1.0: 4, 2.0: 4}


def test_a_fixed_part_and_its_kp_reach_every_point():
    spec = SweepSpec.from_mapping(
        data(
            part={"servo": "mx106", "kp": 20},
            parameter=[{"kind": "servo", "name": "dead_band_deg", "min": 0, "max": 1}],
        )
    )
    for point in sweep_points(spec):
        part = point.simulation.part
        assert (part.servo, part.kp) == ("mx106", 20.0)
        assert part.dead_band_deg == point.values[0]


def test_a_point_compensates_with_one_over_k_of_its_part_on_the_legs():
    robot = load_robot("dircon_biped")
    spec = SweepSpec.from_mapping(data())
    record = load_catalogue()["mx106"]
    point = next(
        p
        for p in sweep_points(spec)
        if (p.simulation.part.servo, p.simulation.part.kp) == ("mx106", 16.0)
    )
    params, servo = servo_settings(robot, point.simulation)
    fit, firmware = record.fit("m1"), record.firmware
    stiffness = (
        fit.motor.kt_Nm_per_A * firmware.vin_V * firmware.error_gain * 16.0 / fit.motor.R_ohm
    )
    legs = params.enabled
    assert legs.any()
    np.testing.assert_array_equal(servo.compliance_deg_per_Nm[~legs], 0.0)  # rigid elsewhere
    np.testing.assert_allclose(params.k_deg_per_Nm[legs], math.degrees(1.0 / stiffness), rtol=1e-12)
    np.testing.assert_allclose(servo.compliance_deg_per_Nm[legs], math.degrees(1.0 / stiffness))
    np.testing.assert_allclose(servo.backlash_deg[legs], record.backlash_deg or 0.0)


@pytest.mark.parametrize(
    ("changes", "said"),
    [
        (
            {"parameter": [{"kind": "part", "name": "servo", "choices": ["xh540_v270"]}]},
            "not a catalogue servo the simulation can run",
        ),
        (
            {"parameter": [{"kind": "part", "name": "servo", "choices": ["mx64", "mx64"]}]},
            "given twice",
        ),
        ({"parameter": [{"kind": "part", "name": "servo", "choices": []}]}, "choices ="),
        (
            {
                "parameter": [
                    {"kind": "part", "name": "servo", "min": 0, "max": 1, "choices": ["mx64"]}
                ]
            },
            "categorical",
        ),
        ({"parameter": [{"kind": "part", "name": "kp", "min": 0, "max": 10}]}, "kp = 0"),
        ({"parameter": [{"kind": "part", "name": "kp", "min": 10, "max": 20}]}, "kp needs a servo"),
        (
            {"parameter": [{"kind": "part", "name": "torque", "min": 1, "max": 2}]},
            "unknown part parameter",
        ),
        (
            {
                "parameter": [
                    {"kind": "gait", "name": "H_s", "min": 0.6, "max": 0.8, "choices": ["mx64"]}
                ]
            },
            "choices are for",
        ),
        (
            {
                "part": {"servo": "mx64"},
                "parameter": [
                    {"kind": "servo", "name": "compliance_deg_per_Nm", "min": 0, "max": 2}
                ],
            },
            "part's 1/K",
        ),
        ({"part": {"servo": "mx64", "gear": 3}}, "unknown key(s) gear"),
        ({"part": {"servo": "mx64"}}, "servo swept and in [part]"),
        ({"simulate": False}, "act(s) only through the simulation"),
    ],
)
def test_what_cannot_be_swept_is_refused_in_one_line(changes, said):
    with pytest.raises(SweepSpecError) as error:
        SweepSpec.from_mapping(data(**changes))
    assert said in str(error.value)
    assert "\n" not in str(error.value)


def test_the_example_sweep_file_reads():
    from pathlib import Path

    from app.core.sweeps.spec import read_sweep_toml

    spec = read_sweep_toml(Path(__file__).parents[2] / "examples" / "sweep_servo_parts.toml")
    assert [p.kind for p in spec.parameters] == ["part", "part"]
    assert spec.n_points == 6


def test_the_example_sweep_over_the_parts_axes_reads_with_its_servo_file():
    from pathlib import Path

    from app.core.sweeps.spec import read_sweep_toml

    spec = read_sweep_toml(Path(__file__).parents[2] / "examples" / "sweep_servo_axes.toml")
    assert spec.servos == ("shop_mx64", "shop_mx106")
    assert [f.name for f in spec.user_servos] == ["workshop_servos.toml"]
    assert spec.pareto[0] == ("servo_cost", "min") and spec.n_points == 4
