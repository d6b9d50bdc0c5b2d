"""`simulate` without servo data sizes the paper's servo to the robot (m·g·h): Roban S14,
which falls on the paper's 1.4 °/(N·m) servo, stands on its own, and the note says which."""

from __future__ import annotations

import json

from tests.conftest import ROBAN_URDF
from tests.test_cli import run


def test_roban_s14_stands_on_its_sized_servos(tmp_path):
    traj = tmp_path / "shift.csv"
    made = run(
        "motion", "com_shift", "--robot", str(ROBAN_URDF), "--param", "shift_m=0.02",
        "--out", str(traj),
    )  # fmt: skip
    assert made.returncode == 0, made.stderr
    result = run("simulate", str(traj), "--robot", str(ROBAN_URDF), "--preset", "plan", "--json")
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    assert report["verdict"].startswith("stays up"), report["verdict"]
    # the audit: 0.146 °/(N·m) and 57 N·m for the 28.7 kg robot
    assert "0.148 °/(N·m)" in report["servo_default"] and "56.8 N·m" in report["servo_default"]
    assert report["stand_check"].startswith("stands"), report["stand_check"]
    assert any("56.8 N·m" in note for note in report["notes"])
