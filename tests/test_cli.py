"""The headless commands, run as a user runs them: a subprocess, its exit code and output."""

from __future__ import annotations

import json
import subprocess
import sys
import xml.etree.ElementTree as ET

import pytest

from robots.catalogue import BUILTIN_ROBOTS
from tests.conftest import ROBAN_URDF, tiny_biped_urdf


def run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "app", *args],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )


def test_robots_json_lists_every_builtin():
    result = run("robots", "--json")
    assert result.returncode == 0, result.stderr
    rows = {row["name"]: row for row in json.loads(result.stdout)}
    assert set(rows) == set(BUILTIN_ROBOTS)
    assert rows["servo_biped"]["n_actuated"] == 12 and rows["servo_biped"]["default"]
    assert rows["dircon_biped"]["mass_kg"] == pytest.approx(18.532)  # gait paper, Table 2


def test_check_json_on_roban():
    result = run("check", str(ROBAN_URDF), "--json")
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    for key in ("ok", "name", "n_actuated", "mass_kg", "feet", "missing_meshes", "problems"):
        assert key in report
    root = ET.parse(ROBAN_URDF).getroot()
    assert report["ok"] is True
    assert report["n_actuated"] == sum(j.get("type") == "revolute" for j in root.iter("joint"))
    assert report["mass_kg"] == pytest.approx(sum(float(m.get("value")) for m in root.iter("mass")))
    assert report["missing_meshes"] == []


@pytest.mark.parametrize(
    "content, reason",
    [
        ("<robot><link name='a'>", "not well-formed XML"),
        ('<!DOCTYPE r [<!ENTITY a "aaaa">]><robot name="&a;"/>', "DTD or XML entities"),
    ],
)
def test_check_bad_file_exits_non_zero_with_one_line(tmp_path, content, reason):
    path = tmp_path / "bad.urdf"
    path.write_text(content)
    result = run("check", str(path))
    assert result.returncode != 0
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and reason in lines[0] and "Traceback" not in result.stderr
    as_json = run("check", str(path), "--json")
    assert json.loads(as_json.stdout) == {"ok": False, "error": lines[0].split(": ", 1)[1]}


def test_check_reports_missing_meshes_but_succeeds(tmp_path):
    path = tmp_path / "r.urdf"
    path.write_text(tiny_biped_urdf(foot_geometry='<mesh filename="gone.stl"/>'))
    result = run("check", str(path), "--json")
    assert result.returncode == 0
    assert {m["uri"] for m in json.loads(result.stdout)["missing_meshes"]} == {"gone.stl"}


def test_bad_feet_option():
    result = run("check", "servo_biped", "--feet", "only_one")
    assert result.returncode != 0 and "two link names" in result.stderr


def test_motion_writes_csv_and_reports_json(tmp_path):
    import numpy as np
    import pinocchio as pin

    from app.core.loading import load_robot
    from app.core.motion_csv import read_trajectory_csv

    out = tmp_path / "shift.csv"
    result = run(
        "motion", "com_shift", "--robot", "servo_biped", "--param", "shift_m=0.043",
        "--param", "side=right", "--dt", "0.02", "--out", str(out), "--json",
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    assert report["ok"] and report["motion"] == "com_shift" and report["robot"] == "servo_biped"
    assert report["params"]["shift_m"] == 0.043 and report["dt_s"] == pytest.approx(0.02)
    robot = load_robot("servo_biped")
    traj = read_trajectory_csv(out, robot)
    assert traj.n_samples == report["n_samples"] and traj.duration == report["duration_s"]
    data = robot.model.createData()
    com = [pin.centerOfMass(robot.model, data, traj.q[k]) for k in (0, -1)]
    assert com[1][1] - com[0][1] == pytest.approx(-0.043, abs=2e-3)
    assert np.all(traj.contacts)


def test_motion_bad_parameter_is_one_line_naming_the_valid_ones(tmp_path):
    result = run(
        "motion", "one_leg_squats", "--param", "depth=0.02", "--out", str(tmp_path / "x.csv")
    )
    assert result.returncode == 1 and "Traceback" not in result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "'depth'" in lines[0] and "depth_m" in lines[0]
    assert not (tmp_path / "x.csv").exists()
    result = run("motion", "moonwalk")
    assert result.returncode == 1 and "step_in_place" in result.stderr
    listed = run("motion", "list", "--json")
    assert listed.returncode == 0 and "one_leg_squats" in {
        m["name"] for m in json.loads(listed.stdout)
    }
