"""`biped-studio servos`, run as a user runs it: a subprocess, its exit code and output."""

from __future__ import annotations

import json

from tests.core.test_servo_catalogue import RECORD
from tests.test_cli import com_shift_csv, run


def test_servos_json_lists_the_catalogue_with_sources_and_stiffness():
    result = run("servos", "--json")
    assert result.returncode == 0, result.stderr
    listing = json.loads(result.stdout)
    rows = {row["key"]: row for row in listing["servos"]}
    assert {"mx64", "mx106", "xl320", "xl330_m288"} <= set(rows)
    mx64 = rows["mx64"]
    assert mx64["sources"]["stall_torque_Nm"].startswith("https://emanual.robotis.com/")
    # K = kt·vin·error_gain·kp/R with BAM's m6 fit (kt 1.6017, R 2.3164) and firmware
    # (15 V, kp 32, error gain 0.158): ≈ 52 N·m/rad, ≈ 1.1 °/(N·m) (shared README).
    assert abs(mx64["fits"]["m6"]["stiffness_Nm_per_rad"] - 52.4) < 0.1
    assert abs(mx64["fits"]["m6"]["compliance_deg_per_Nm"] - 1.09) < 0.01
    # The m1 fit identifies other motor constants (kt 1.6225, R 3.9494): another K.
    m1 = 1.6224667906987444 * 15 * 0.158 * 32 / 3.949433673232461
    assert abs(mx64["fits"]["m1"]["stiffness_Nm_per_rad"] - m1) < 1e-9
    assert "feetech_sts3215_7_4V" in listing["identified_only"]


def test_servos_table_and_a_user_file(tmp_path):
    path = tmp_path / "mine.toml"
    path.write_text(RECORD)
    result = run("servos", "--servos", str(path))
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert any(line.startswith("my_servo ") for line in lines)
    assert any(line.startswith("mx64 ") and "31.2 / 52.4" in line for line in lines)


def test_a_bad_user_servo_is_one_line_and_exit_1(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(RECORD.replace("stall_torque_Nm = 3.0", "stall_torque_Nm = -3.0"))
    result = run("servos", "--servos", str(path))
    assert result.returncode == 1
    assert result.stdout == ""
    (line,) = result.stderr.strip().splitlines()
    assert "stall_torque_Nm" in line and "Traceback" not in result.stderr


def test_simulate_on_catalogue_servos_reports_stiffness_and_energy(tmp_path):
    motion = com_shift_csv(tmp_path)
    parts = tmp_path / "servo.toml"
    parts.write_text('servo = "mx106"\n[joints.left_knee]\nservo = "mx64"\nkp = 40\n')
    result = run("simulate", str(motion), "--preset", "plan", "--servo", str(parts), "--json")
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    knee = next(row for row in report["servos"] if row["joint"] == "left_knee")
    # MX-64 m1 fit (kt 1.6225, R 3.9494) at 15 V, error gain 0.158, kp 40.
    assert (
        abs(knee["stiffness_Nm_per_rad"] - 1.6224667906987444 * 15 * 0.158 * 40 / 3.949433673232461)
        < 1e-6
    )
    assert report["energy"]["total_electrical_J"] > 0
    assert not report["fell"]


def test_simulate_with_a_bad_kp_is_one_line(tmp_path):
    motion = com_shift_csv(tmp_path)
    parts = tmp_path / "servo.toml"
    parts.write_text('servo = "mx106"\nkp = 1e9\n')
    result = run("simulate", str(motion), "--preset", "plan", "--servo", str(parts))
    assert result.returncode == 1
    (line,) = result.stderr.strip().splitlines()
    assert "kp" in line and "firmware's range" in line


def test_compensation_from_the_parts_straightens_the_torso(tmp_path):
    motion = com_shift_csv(tmp_path)
    parts = tmp_path / "servo.toml"
    parts.write_text('servo = "mx106"\n')
    result = run(
        "simulate", str(motion), "--preset", "parts", "--baseline", "--servo", str(parts), "--json"
    )
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    with_k, without = report, report["baseline"]
    assert not with_k["fell"] and not without["fell"]
    assert with_k["max_roll_error_deg"] < 0.5 * without["max_roll_error_deg"]
    result = run("simulate", str(motion), "--preset", "parts")
    assert result.returncode == 1 and "--servo file that names servos" in result.stderr


def test_servos_says_which_cannot_be_simulated_and_why():
    result = run("servos")
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert any(line.startswith("mx64 ") and line.endswith("BAM m1/m6") for line in lines)
    assert any(line.startswith("xm540_w270 ") and line.endswith("  -") for line in lines)
    (why,) = [line for line in lines if line.startswith("cannot be simulated (")]
    assert "xm540_w270" in why and "no firmware constants" in why
    listing = json.loads(run("servos", "--json").stdout)
    rows = {row["key"]: row for row in listing["servos"]}
    assert "no identified motor model" in rows["mx28"]["not_simulated"]
    assert rows["mx64"]["not_simulated"] is None
