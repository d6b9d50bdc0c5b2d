"""The numbered scripts in examples/ run as a user runs them (a fresh Python process) and
print what they claim, checked against independent facts (the URDF's masses, m·g, the
targets and settings they set, a brute-force Pareto front)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from tests.conftest import REPO

EXAMPLES = sorted((REPO / "examples").glob("[0-9][0-9]_*.py"))
MAX_LINES = 60


def _numbers(pattern: str, text: str) -> list[float]:
    found = re.search(pattern, text)
    assert found is not None, f"{pattern!r} not in the output:\n{text}"
    return [float(g) for g in found.groups()]


def _check_01(out: str) -> None:
    urdf = REPO / "robots" / "servo_biped" / "servo_biped.urdf"
    mass = sum(float(m.get("value", "nan")) for m in ET.parse(urdf).iter("mass"))
    (printed,) = _numbers(r"actuated joints, ([\d.]+) kg", out)
    assert printed == pytest.approx(mass, abs=1e-3)


def _check_02(out: str) -> None:
    (raised,) = _numbers(r"right foot raised by ([\d.-]+) mm", out)
    assert raised == pytest.approx(30.0, abs=0.1)  # the script's target: 3 cm up


def _check_03(out: str) -> None:
    assert "read back equal: True" in out


def _check_04(out: str) -> None:
    fz, mg = _numbers(r"contact forces at t = 0: ([\d.]+) N \(m·g = ([\d.]+) N\)", out)
    assert fz == pytest.approx(mg, rel=0.01)  # standing still: the feet carry the weight


def _check_05(out: str) -> None:
    (planned,) = _numbers(r"as planned +.*max \|roll\| ([\d.]+)°", out)
    (compensated,) = _numbers(r"compensated +stays up[^:\n]*: max \|roll\| ([\d.]+)°", out)
    assert compensated < planned  # the paper's claim: compensation keeps the torso upright


def _check_06(out: str) -> None:
    left, right = _numbers(r"steps ([\d.]+) / ([\d.]+) m", out)
    assert left + right == pytest.approx(0.2, abs=1e-3)  # step_length_m: the cycle's advance


def _check_07(out: str) -> None:
    rows = re.findall(r"#(\d+) \([^)]*\): SR ([\d.]+), max \|tau\| ([\d.]+)", out)
    points = {int(i): (float(sr), float(tau)) for i, sr, tau in rows}
    assert len(points) == 4
    front = {int(i) for i in re.findall(r"\d+", out.split("Pareto front of SR vs max torque:")[1])}
    brute = {
        i
        for i, (sr, tau) in points.items()
        if not any(
            s <= sr and t <= tau and (s, t) != (sr, tau) for j, (s, t) in points.items() if j != i
        )
    }
    assert front == brute


CHECKS = {
    "01": _check_01,
    "02": _check_02,
    "03": _check_03,
    "04": _check_04,
    "05": _check_05,
    "06": _check_06,
    "07": _check_07,
}


def test_examples_are_numbered_and_checked() -> None:
    assert len(EXAMPLES) >= 6
    assert [p.name[:2] for p in EXAMPLES] == [f"{n:02d}" for n in range(1, len(EXAMPLES) + 1)]
    assert {p.name[:2] for p in EXAMPLES} == set(CHECKS)


@pytest.mark.parametrize("script", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_example_runs(script: Path, tmp_path: Path) -> None:
    assert len(script.read_text(encoding="utf-8").splitlines()) <= MAX_LINES
    args = [str(tmp_path / "motion.csv")] if script.name.startswith("03_") else []
    env = {**os.environ, "PYTHONPATH": str(REPO), "OMP_NUM_THREADS": "1"}
    done = subprocess.run(
        [sys.executable, str(script), *args],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    assert "Traceback" not in done.stderr
    CHECKS[script.name[:2]](done.stdout)
