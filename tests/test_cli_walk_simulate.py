"""servo_biped's planned 6-step walk, simulated as the CLI runs it: does it walk?

Distance is read from MuJoCo's own root body (the simulation CSV's base_x column, written from
MuJoCo's qpos) against the plan's (the walk CSV's base x), not from the verdict's numbers.
Issue 26's target: ≥ 90 % of the planned distance with eq 7. Eq 7 on the load torque alone
lags the swing leg by c·D·q̇ (servo_biped: c = 1.4 °/(N·m), D = 1 N·m·s/rad) and the steps come
up short; eq 7 on the drive torque (`--drive-torque`) covers the distance.
"""

from __future__ import annotations

import csv
import json

import pytest

from tests.test_cli import run

STEPS = "6"


def _column(path, name: str) -> list[float]:
    with open(path, newline="", encoding="utf-8") as file:
        rows = list(csv.reader(file))
    i = rows[0].index(name)
    return [float(row[i]) for row in rows[1:]]


@pytest.fixture(scope="module")
def walk(tmp_path_factory):
    folder = tmp_path_factory.mktemp("walk")
    out = folder / "walk.csv"
    result = run("plan", "--robot", "servo_biped", "--steps", STEPS, "--out", str(out))
    assert result.returncode == 0, result.stderr
    return folder, out


def _covered(walk, *options: str) -> tuple[float, float, dict]:
    folder, traj = walk
    sim = folder / "sim.csv"
    result = run(
        "simulate", str(traj), "--robot", "servo_biped", "--preset", "uniform", *options,
        "--out", str(sim), "--json",
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    planned_x = _column(traj, "base_x [m]")
    simulated_x = _column(sim, "base_x [m]")
    return simulated_x[-1] - simulated_x[0], planned_x[-1] - planned_x[0], json.loads(result.stdout)


def test_eq7_on_the_drive_torque_walks_the_planned_distance(walk):
    covered, planned, report = _covered(walk, "--drive-torque")
    assert planned > 0.5  # six 7.7 cm steps and the start/stop: 0.58 m
    assert covered >= 0.9 * planned
    assert not report["fell"]
    assert report["label"] == "with compensation (drive torque)"


def test_eq7_on_the_load_torque_alone_falls_short(walk):
    covered, planned, _ = _covered(walk)
    assert covered < 0.9 * planned  # the lag the drive torque removes
