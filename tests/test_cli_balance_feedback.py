"""`biped-studio simulate --balance-feedback`, run as a user runs it: servo_biped's CoM shift
on leg servos too soft to stand (5 °/(N·m): the stand check says so) goes over without the
feedback and stays up with it, read from the base height MuJoCo wrote in the run's CSV; the
report names the feedback and the gains asked for; a run with the feedback also gives the
verdict of the same run without it (printed beside, `verdict_without_feedback`), equal to
that of a run made without it."""

from __future__ import annotations

import csv
import json

import pytest

from tests.test_cli import com_shift_csv, run


@pytest.fixture(scope="module")
def soft(tmp_path_factory):
    folder = tmp_path_factory.mktemp("balance")
    traj = com_shift_csv(folder)
    servo = folder / "soft.toml"
    servo.write_text("compliance_deg_per_Nm = 5.0\nbacklash_deg = 0.5\n")
    return folder, traj, servo


def _base_z(path) -> list[float]:
    with open(path, newline="", encoding="utf-8") as file:
        rows = list(csv.reader(file))
    column = rows[0].index("base_z [m]")
    return [float(row[column]) for row in rows[1:]]


def test_the_feedback_keeps_a_soft_robot_up_and_says_so(soft):
    folder, traj, servo = soft
    common = ("simulate", str(traj), "--robot", "servo_biped", "--preset", "plan")
    without = run(*common, "--servo", str(servo), "--out", str(folder / "off.csv"), "--json")
    assert without.returncode == 0, without.stderr
    report = json.loads(without.stdout)
    assert report["stand_check"].startswith("cannot stand")  # the stiffness balance says so
    assert report["balance_feedback"] == {"on": False, "gains": None}
    assert "balance" not in report["verdict"]
    z_off = _base_z(folder / "off.csv")
    assert min(z_off) < 0.75 * z_off[0]  # it went over

    on = run(
        *common, "--servo", str(servo), "--balance-feedback", "--balance-gain", "hip_kp=0.8",
        "--out", str(folder / "on.csv"),
    )  # fmt: skip
    assert on.returncode == 0, on.stderr
    assert "without compensation: stays up with balance feedback" in on.stdout
    # the gains asked for (hips Kp 0.8), the rest the documented defaults
    assert (
        "balance feedback (IMU → ankles/hips) on: ankles Kp 1, Kd 0.05 s; hips Kp 0.8, Kd 0.02 s;"
        " ≤ 10° per joint; largest offset"
    ) in on.stdout
    z_on = _base_z(folder / "on.csv")
    assert min(z_on) > 0.9 * z_on[0]  # up all along
    # one run says both verdicts: the same run without the feedback is the run above
    fell = f"falls at {report['fall_time_s']:.2f} s ({report['fall_link']})"
    assert f"without compensation: with balance feedback: stays up · without: {fell}" in on.stdout
    both = run(*common, "--servo", str(servo), "--balance-feedback", "--json")
    assert both.returncode == 0, both.stderr
    both_report = json.loads(both.stdout)
    assert both_report["verdict"].startswith("stays up with balance feedback")
    assert both_report["verdict_without_feedback"] == report["verdict"]
    assert "verdict_without_feedback" not in report


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (("--balance-gain", "hip_kp=1"), "--balance-gain goes with --balance-feedback"),
        (("--balance-feedback", "--balance-gain", "knee_kp=1"), "NAME one of ankle_kp"),
    ],
)
def test_bad_balance_options_get_one_line(soft, options, message):
    _folder, traj, _servo = soft
    result = run(
        "simulate", str(traj), "--robot", "servo_biped", "--preset", "plan", *options
    )  # fmt: skip
    assert result.returncode == 1, result.stdout
    assert message in result.stderr and len(result.stderr.strip().splitlines()) == 1
