"""`plan --compare --simulate` on servo_biped (issue 26, Table 4 like for like): both gaits
walked six steps and simulated, their SR from electrical energy and its symmetric / baseline
ratio beside the paper's 0.772 / 1.299.

References, none of them the command's own figures: the ratio from the two SRs it prints;
each SR from the energy and distance it prints and the robot's weight; the symmetric walk
(written by --out) simulated again by `simulate --out` and its electrical energy recomputed
from the simulation CSV's recorded columns (servo torque less the back-EMF damping D·q̇, the
joint angles' steps, and the MX-64 motor of the catalogue geared to the 6 N·m limit); the
distance from that CSV's base columns.
"""

from __future__ import annotations

import csv
import json
import re

import numpy as np
import pytest

from tests.test_cli import run

GRAVITY = 9.81
FLOAT = r"([0-9.]+)"


@pytest.fixture(scope="module")
def compared(tmp_path_factory):
    folder = tmp_path_factory.mktemp("table4")
    walk = folder / "walk.csv"
    result = run(
        "plan", "--robot", "servo_biped", "--compare", "--simulate", "--steps", "6",
        "--out", str(walk), timeout_s=600,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    return folder, walk, result.stdout


def _walk_line(text: str, name: str) -> str:
    match = re.search(rf"^  {name}: (.*)$", text, re.MULTILINE)
    assert match, text
    return match.group(1)


def _printed_sr(line: str) -> tuple[float, float, float]:
    """(energy [J], distance [m], SR electrical) of a walk's printed line."""
    match = re.search(
        rf"{FLOAT} J electrical (?:up to the fall at [0-9.]+ s, over the {FLOAT} m it covered"
        rf"|over {FLOAT} m): SR {FLOAT} electrical, {FLOAT} planned work",
        line,
    )
    assert match, line
    energy, fell_d, walked_d, sr, _planned = match.groups()
    return float(energy), float(fell_d or walked_d), float(sr)


def test_the_ratio_and_each_sr_from_the_printed_numbers(compared):
    from app.core.robot.loading import load_robot

    _folder, _walk, text = compared
    weight = load_robot("servo_biped").mass_kg * GRAVITY
    srs = []
    for name in ("symmetric", "baseline"):
        energy, distance, sr = _printed_sr(_walk_line(text, name))
        assert distance > 0.1 and energy > 0.0
        assert sr == pytest.approx(energy / (weight * distance), rel=0.01)  # 3 figures printed
        srs.append(sr)
    match = re.search(
        rf"SR electrical \(simulated walks\): symmetric / baseline {FLOAT} \(ours\), "
        rf"{FLOAT} \(paper, Table 4: measured motor energy\)",
        text,
    )
    assert match, text
    assert float(match.group(1)) == pytest.approx(srs[0] / srs[1], rel=0.01)
    assert float(match.group(2)) == pytest.approx(0.772 / 1.299, abs=5e-4)  # the paper's
    # the baseline walk falls on servo_biped's servos: its SR is over what it covered
    baseline = _walk_line(text, "baseline")
    if baseline.startswith("falls"):
        assert "up to the fall at" in baseline and "it covered" in baseline, baseline


def _columns(path) -> tuple[list[str], np.ndarray]:
    with open(path, newline="", encoding="utf-8") as file:
        rows = list(csv.reader(file))
    return rows[0], np.array([[float(x) for x in row] for row in rows[1:]])


def test_the_symmetric_walks_energy_from_the_recorded_columns(compared):
    from app.core.robot.loading import load_robot
    from app.core.servo.catalogue import load_catalogue

    folder, walk, text = compared
    sim = folder / "sim.csv"
    result = run(
        "simulate", str(walk), "--robot", "servo_biped", "--preset", "uniform",
        "--drive-torque", "--out", str(sim), "--json",
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    ideal = json.loads(result.stdout)["ideal_servo_energy"]
    assert not ideal["fell"]
    header, rows = _columns(sim)
    names = [h[2:-6] for h in header if h.startswith("q:")]
    q = rows[:, [header.index(f"q:{n} [rad]") for n in names]]
    tau = rows[:, [header.index(f"tau:{n} [N·m]") for n in names]]
    t = rows[:, header.index("t [s]")]
    dt = t[1] - t[0]
    # the default motor, from the catalogue: the MX-64 geared to servo_biped's 6 N·m
    mx64 = load_catalogue()["mx64"]
    motor = mx64.fit().motor
    kt, r_ohm = motor.kt_Nm_per_A * 6.0 / mx64.stall_torque_Nm, motor.R_ohm
    speed = np.diff(q, axis=0) / dt
    torque = tau[:-1] - 1.0 * speed  # servo_biped's D = 1 N·m·s/rad (URDF 6 N·m / 6 rad/s)
    drawn = np.maximum(torque * speed + (torque / kt) ** 2 * r_ohm, 0.0).sum() * dt
    assert drawn > 10.0  # it draws: the comparison means something
    assert ideal["total_electrical_J"] == pytest.approx(drawn, rel=0.03)
    # the distance from the CSV's base columns, the SR from them and the robot's weight
    xy = rows[:, [header.index("base_x [m]"), header.index("base_y [m]")]]
    plan_header, plan = _columns(walk)
    way = plan[-1, [plan_header.index("base_x [m]"), plan_header.index("base_y [m]")]]
    way -= plan[0, [plan_header.index("base_x [m]"), plan_header.index("base_y [m]")]]
    distance = float((xy[-1] - xy[0]) @ way / np.linalg.norm(way))  # along the planned way
    weight = load_robot("servo_biped").mass_kg * GRAVITY
    assert ideal["sr_electrical"] == pytest.approx(drawn / (weight * distance), rel=0.03)
    # and `plan --compare --simulate` printed the same run's figures
    energy, printed_distance, sr = _printed_sr(_walk_line(text, "symmetric"))
    assert energy == pytest.approx(drawn, rel=0.03)
    assert printed_distance == pytest.approx(distance, abs=0.006)
    assert sr == pytest.approx(ideal["sr_electrical"], rel=0.01)


def test_simulate_without_compare_is_one_line():
    result = run("plan", "--robot", "servo_biped", "--simulate")
    assert result.returncode != 0
    assert "--simulate goes with --compare" in result.stderr
    assert "Traceback" not in result.stderr
