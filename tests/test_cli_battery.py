"""`biped-studio simulate --servo … --battery-Wh`: the figures from the run's own energy."""

from __future__ import annotations

import json

import pytest

from tests.test_cli import com_shift_csv, run


def _refuse(name: str) -> None:
    raise AssertionError(f"{name} in the JSON")


def test_battery_minutes_and_currents_follow_from_the_energy(tmp_path):
    motion = com_shift_csv(tmp_path)
    parts = tmp_path / "servo.toml"
    parts.write_text('servo = "mx106"\nvin_V = 14.0\n')
    result = run(
        "simulate", str(motion), "--preset", "plan", "--servo", str(parts),
        "--battery-Wh", "20", "--json",
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout, parse_constant=_refuse)  # strict JSON: no NaN
    energy, figures = report["energy"], report["energy_figures"]
    drawn = sum(max(e, 0.0) for e in energy["electrical_J"])
    power = drawn / energy["duration_s"]
    assert figures["average_power_W"] == pytest.approx(power)
    assert figures["average_current_A"] == pytest.approx(power / 14.0)
    assert figures["battery_minutes"] == pytest.approx(60.0 * 20.0 / power)
    assert figures["peak_current_A"] == pytest.approx(max(energy["peak_current_A"]))
    assert figures["sr_electrical"] is None  # a CoM shift travels < 0.1 m


@pytest.mark.parametrize(
    ("extra", "words"),
    [(("--battery-Wh", "nan"), "Wh"), (("--battery-Wh", "-3"), "Wh"), ((), "servo parts")],
)
def test_a_bad_battery_is_one_line_and_exit_1(tmp_path, extra, words):
    motion = com_shift_csv(tmp_path)
    args = ["simulate", str(motion), "--preset", "plan", *extra]
    if not extra:
        args += ["--battery-Wh", "10"]  # without a --servo file that names servos
    result = run(*args)
    assert result.returncode == 1
    (line,) = result.stderr.strip().splitlines()
    assert words in line and "Traceback" not in result.stderr


def test_servo_masses_change_the_robot_the_simulation_runs(tmp_path):
    from app.core.robot.loading import load_robot
    from app.core.servo.catalogue import load_catalogue

    motion = com_shift_csv(tmp_path)
    parts = tmp_path / "servo.toml"
    parts.write_text('servo = "mx106"\n')
    args = ["simulate", str(motion), "--preset", "plan", "--servo", str(parts), "--json"]
    plain = json.loads(run(*args).stdout)
    result = run(*args, "--servo-masses", "none")
    assert result.returncode == 0, result.stderr
    heavy = json.loads(result.stdout)
    robot = load_robot("servo_biped")
    after = robot.mass_kg + robot.n_actuated * load_catalogue()["mx106"].mass_kg
    assert f"→ {after:.3f} kg" in heavy["servo_masses"]
    assert heavy["rms_joint_error_deg"] != plain["rms_joint_error_deg"]  # other dynamics
