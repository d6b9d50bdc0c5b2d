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
