"""Roban S14 (28.7 kg) walks on the servos sized to it, as the CLI runs it: no fall, and the
distance its plan asks, read from MuJoCo's own root body.

Distance is the simulation CSV's base_x column (written from MuJoCo's qpos) against the walk
CSV's base x, not the verdict's numbers. What makes S14 walk (measured, docs/simulation.md):
a start that brings the body to the gait's speed with both feet down, within the soles (the
walk's ramp, app/core/walking/walk.py), which S14's legs reach with steps of 5.9 cm; its
default 16.9 cm steps start with a jump in speed, and the body that never gets the speed
falls backwards, on rigid servos too. Eq 7 on the servos' drive torque (`--drive-torque`).
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.conftest import ROBAN_URDF
from tests.test_cli import run
from tests.test_cli_walk_simulate import _column

STEP_LENGTH_M = 0.1185
"""Two steps' advance [m]: 0.35 of S14's default 0.3386 m (0.26 of its leg length per step)."""


def planned_walk(folder: Path, *options: str, timeout_s: float) -> tuple[Path, Path, dict]:
    """`plan --robot S14 --steps 4 OPTIONS --json` writing folder/walk.csv: (folder, the walk
    CSV, plan's report)."""
    out = folder / "walk.csv"
    result = run(
        "plan", "--robot", str(ROBAN_URDF), "--steps", "4", *options, "--out", str(out), "--json",
        timeout_s=timeout_s,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    return folder, out, json.loads(result.stdout)


@pytest.fixture(scope="module")
def walk(tmp_path_factory):
    folder = tmp_path_factory.mktemp("roban_walk")
    config = folder / "plan.toml"
    config.write_text(f"step_length_m = {STEP_LENGTH_M}\n", encoding="utf-8")
    return planned_walk(folder, "--config", str(config), timeout_s=300)


def assert_starts_at_the_gaits_speed(traj, report) -> None:
    """No jump in speed at the first lift-off, read off the walk CSV's base x (central finite
    differences two samples either side), and `plan` says none."""
    assert not any("jump in speed" in note for note in report["walk"]["notes"])
    t, x = _column(traj, "t [s]"), _column(traj, "base_x [m]")
    first_lift = report["walk"]["footprints"][0]["t_off_s"]
    k = min(range(len(t)), key=lambda i: abs(t[i] - first_lift))
    dt = t[1] - t[0]
    before, after = (x[k] - x[k - 2]) / (2 * dt), (x[k + 2] - x[k]) / (2 * dt)
    assert after > 0.1  # walking forward at lift-off
    assert abs(after - before) < 0.25 * after


def assert_walks_its_planned_distance(folder, traj) -> dict:
    """Simulate the walk on the servos sized to S14, eq 7 on the drive torque: no fall, and the
    distance covered (the simulation CSV's base_x column, MuJoCo's qpos) within 0.9-1.2 of the
    planned one (the walk CSV's base x, over 0.25 m: four steps and the start and stop);
    `simulate --json`'s report."""
    sim = folder / "sim.csv"
    result = run(
        "simulate", str(traj), "--robot", str(ROBAN_URDF), "--preset", "uniform",
        "--drive-torque", "--out", str(sim), "--json", timeout_s=300,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    assert not report["fell"], report["verdict"]
    assert report["verdict_kind"] != "falls"
    planned_x, simulated_x = _column(traj, "base_x [m]"), _column(sim, "base_x [m]")
    planned, covered = planned_x[-1] - planned_x[0], simulated_x[-1] - simulated_x[0]
    assert planned > 0.25
    assert 0.9 * planned <= covered <= 1.2 * planned, (covered, planned)
    return report


def test_the_walk_starts_at_the_gaits_speed(walk):
    _, traj, report = walk
    # The start ramp reaches the gait's speed with both feet down.
    assert_starts_at_the_gaits_speed(traj, report)


def test_roban_walks_its_planned_distance_without_a_fall(walk):
    folder, traj, _ = walk
    report = assert_walks_its_planned_distance(folder, traj)  # four 5.9 cm steps
    assert "covers" in report["verdict"]  # the CLI says how far it walked
    assert "sized to biped_s13" in report["servo_default"]
