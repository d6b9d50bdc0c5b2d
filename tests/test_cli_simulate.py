"""`biped-studio simulate`, run as a user runs it: a subprocess, its exit code and output."""

from __future__ import annotations

import csv
import json
import math

import pytest

from app.core.robot.loading import load_robot
from tests.test_cli import com_shift_csv, run

G = 9.81


@pytest.fixture(scope="module")
def motion(tmp_path_factory):
    folder = tmp_path_factory.mktemp("simulate")
    return folder, com_shift_csv(folder)


def _columns(path) -> dict[str, list[float]]:
    with open(path, newline="", encoding="utf-8") as file:
        rows = list(csv.reader(file))
    return {name: [float(row[i]) for row in rows[1:]] for i, name in enumerate(rows[0])}


def test_simulate_the_plan_writes_a_run_and_a_verdict(motion):
    folder, traj = motion
    servo = folder / "servo.toml"
    servo.write_text("compliance_deg_per_Nm = 0.0\nbacklash_deg = 0.0\n")  # rigid servos
    out = folder / "sim.csv"
    result = run(
        "simulate", str(traj), "--robot", "servo_biped", "--preset", "plan",
        "--servo", str(servo), "--hold", "linear", "--out", str(out), "--json",
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    for key in (
        "fell", "fall_time_s", "max_abs_roll_deg", "max_abs_pitch_deg",
        "rms_joint_error_deg", "real_time_factor", "verdict", "lifted_foot_load_s",
        "lifted_foot_peak_load_frac",
    ):  # fmt: skip
        assert key in report
    assert report["fell"] is False and report["fall_time_s"] is None
    assert report["verdict"] == "stays up" and report["lifted_foot_load_s"] == 0.0
    assert "distance_planned_m" not in report  # a CoM shift does not travel
    columns = _columns(out)
    n = len(columns["t [s]"])
    assert n == report["n_samples"] == 201
    weight = load_robot("servo_biped").mass_kg * G
    for k in range(0, n, 20):
        # The soles carry the robot, and the roll column is the quaternion's roll.
        total = columns["force_left_z [N]"][k] + columns["force_right_z [N]"][k]
        assert total == pytest.approx(weight, rel=0.05)
        x, y, z, w = (columns[f"base_q{c} [1]"][k] for c in "xyzw")
        roll = math.degrees(math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y)))
        assert columns["roll [deg]"][k] == pytest.approx(roll, abs=1e-9)
    assert max(abs(v) for v in columns["roll [deg]"]) == pytest.approx(
        report["max_abs_roll_deg"], rel=1e-9
    )


def test_a_command_file_and_its_coefficients_give_the_same_run(motion):
    folder, traj = motion
    tau = folder / "tau.csv"
    assert run("feedforward", str(traj), "--out", str(tau)).returncode == 0
    coeffs = folder / "k.toml"
    coeffs.write_text(
        "[joints.left_knee]\nk_deg_per_Nm = 1.4\n[joints.left_hip_roll]\nk_deg_per_Nm = 1.4\n"
    )
    cmd = folder / "cmd.csv"
    made = run(
        "compensate", str(traj), "--tau", str(tau), "--coeffs", str(coeffs), "--out", str(cmd)
    )
    assert made.returncode == 0, made.stderr
    by_file = run("simulate", str(traj), "--cmd", str(cmd), "--json")
    by_coeffs = run(
        "simulate", str(traj), "--compensation", str(coeffs), "--tau", str(tau), "--json",
        "--baseline",
    )  # fmt: skip
    assert by_file.returncode == 0 and by_coeffs.returncode == 0, by_coeffs.stderr
    a, b = json.loads(by_file.stdout), json.loads(by_coeffs.stdout)
    for key in ("max_abs_roll_deg", "max_abs_pitch_deg", "rms_joint_error_deg"):
        assert a[key] == pytest.approx(b[key], abs=1e-9)
    assert b["baseline"]["label"] == "without compensation"


@pytest.mark.parametrize(
    ("setup", "message"),
    [
        ("nan", "give a finite number"),
        ("short", "command rows but the motion has"),
        ("servo", "no joint named 'elbow'"),
        ("robot", "unknown column"),
    ],
)
def test_bad_input_exits_1_with_one_line(motion, setup, message):
    folder, traj = motion
    args = ["simulate", str(traj), "--preset", "plan"]
    if setup in ("nan", "short"):
        names = load_robot("servo_biped").joint_names
        rows = [",".join(["t [s]", *(f"q_cmd:{name} [rad]" for name in names)])]
        rows += [",".join([f"{k * 0.01}"] + ["0.3"] * len(names)) for k in range(201)]
        if setup == "nan":
            rows[5] = rows[5].replace("0.3", "nan", 1)
        cmd = folder / f"{setup}.csv"
        cmd.write_text("\n".join(rows[:50] if setup == "short" else rows) + "\n")
        args = ["simulate", str(traj), "--cmd", str(cmd)]
    elif setup == "servo":
        servo = folder / "bad_servo.toml"
        servo.write_text("[joints.elbow]\nbacklash_deg = 1\n")
        args += ["--servo", str(servo)]
    else:
        args += ["--robot", "dircon_biped"]
    result = run(*args)
    assert result.returncode == 1
    assert len(result.stderr.strip().splitlines()) == 1
    assert message in result.stderr


def test_a_travelling_motion_reports_its_distance_and_footsteps(tmp_path):
    """Two 4 cm steps on stiff servos: the report gives the planned distance (the motion
    file's base x from first to last row), how far the simulated robot went, and one
    placement error per footstep (one per 0 → 1 in the file's contact columns)."""
    traj, servo = tmp_path / "steps.csv", tmp_path / "servo.toml"
    made = run(
        "motion", "step_in_place", "--robot", "servo_biped", "--param", "stride_m=0.04",
        "--param", "steps=2", "--out", str(traj),
    )  # fmt: skip
    assert made.returncode == 0, made.stderr
    servo.write_text("compliance_deg_per_Nm = 0.0\nbacklash_deg = 0.0\n")
    args = ["simulate", str(traj), "--preset", "plan", "--servo", str(servo)]
    result = run(*args, "--json")
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    columns = _columns(traj)
    dx = columns["base_x [m]"][-1] - columns["base_x [m]"][0]
    dy = columns["base_y [m]"][-1] - columns["base_y [m]"][0]
    assert report["distance_planned_m"] == pytest.approx(math.hypot(dx, dy), abs=1e-9)
    landings = sum(
        1
        for name in ("contact_left [0/1]", "contact_right [0/1]")
        for a, b in zip(columns[name], columns[name][1:], strict=False)
        if a == 0 and b == 1
    )
    assert landings == 2 and len(report["footstep_errors_m"]) == landings
    assert 0.5 * dx < report["distance_covered_m"] < 1.5 * dx
    text = run(*args)
    assert text.returncode == 0, text.stderr
    assert f"covers {report['distance_covered_m']:.2f} m of {dx:.2f} m planned" in text.stdout


def test_servos_too_soft_to_stand_are_told_before_the_run_and_the_run_agrees(motion):
    """Ankle servos of 9 °/(N·m) (the others 1.4): the stiffness balance says the robot cannot
    stand and how soft its ankles may be; the simulation of the same servos falls."""
    folder, traj = motion
    servo = folder / "soft_ankles.toml"
    servo.write_text(
        "compliance_deg_per_Nm = 1.4\nbacklash_deg = 0.0\n"
        "[joints.left_ankle_pitch]\ncompliance_deg_per_Nm = 9.0\n"
        "[joints.right_ankle_pitch]\ncompliance_deg_per_Nm = 9.0\n"
    )
    args = ["simulate", str(traj), "--preset", "plan", "--servo", str(servo)]
    report = json.loads(run(*args, "--json").stdout)
    assert report["stand_check"].startswith("cannot stand: needs ≤ ")
    assert report["fell"] is True and report["verdict"].startswith("falls at")
    text = run(*args)
    assert text.returncode == 0 and "note: servo_biped cannot stand: needs ≤" in text.stderr
