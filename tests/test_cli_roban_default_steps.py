"""Roban S14's default walk, as `plan` gives it without a config: its robot-derived 16.9 cm
steps leave no start ramp the legs can follow (the walk would jump to the gait's speed and
fall), so the default step is shortened to the longest at which the walk can start, `plan`
says so, and the walk stays up on the servos sized to S14 and covers its planned distance.

Independent of the planner's numbers: the speed at the first lift-off is read off the walk
CSV's base x (finite differences), the distance from the simulation CSV's base_x column
(written from MuJoCo's qpos), and the robot-derived default from `robot_gait_defaults`.
A step length the user sets is kept as set, with the jump's note.
"""

from __future__ import annotations

import json

import pytest

from tests.conftest import ROBAN_URDF
from tests.test_cli import run
from tests.test_cli_walk_simulate_roban import (
    assert_starts_at_the_gaits_speed,
    assert_walks_its_planned_distance,
    planned_walk,
)


@pytest.fixture(scope="module")
def default_step_m():
    from app.core.collocation.defaults import robot_gait_defaults
    from app.core.robot.loading import load_robot

    return robot_gait_defaults(load_robot(str(ROBAN_URDF))).settings.step_length_m


@pytest.fixture(scope="module")
def walk(tmp_path_factory):
    return planned_walk(tmp_path_factory.mktemp("roban_default_walk"), timeout_s=600)


def test_the_default_step_is_shortened_and_plan_says_so(walk, default_step_m):
    report = walk[2]
    assert default_step_m > 0.3  # 16.9 cm steps: S14's size, not the paper's 0.2 m
    step = report["step_length_m"]
    assert 0.25 * default_step_m < step < 0.6 * default_step_m
    assert sum(report["step_lengths_m"]) == pytest.approx(step, abs=1e-4)
    shortened = [n for n in report["settings_notes"] if n.startswith("default steps shortened")]
    assert len(shortened) == 1
    assert f"from {50 * default_step_m:.1f} to {50 * step:.1f} cm" in shortened[0]
    assert not any("jump in speed" in note for note in report["walk"]["notes"])


def test_the_walk_starts_at_the_gaits_speed(walk):
    _, traj, report = walk
    assert_starts_at_the_gaits_speed(traj, report)


def test_the_default_walk_stays_up_and_covers_its_distance(walk):
    folder, traj, _ = walk
    assert_walks_its_planned_distance(folder, traj)


def test_a_step_the_user_sets_is_kept(walk, tmp_path, default_step_m):
    _, _, report = walk
    longer = round(report["step_length_m"] + default_step_m / 16, 4)  # past the search's bracket
    config = tmp_path / "plan.toml"
    config.write_text(f"step_length_m = {longer}\n", encoding="utf-8")
    result = run(
        "plan", "--robot", str(ROBAN_URDF), "--config", str(config), "--steps", "2", "--json",
        timeout_s=300,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    kept = json.loads(result.stdout)
    assert kept["step_length_m"] == longer
    assert sum(kept["step_lengths_m"]) == pytest.approx(longer, abs=1e-4)
    assert not any(n.startswith("default steps") for n in kept["settings_notes"])
    assert any("starts with a jump in speed" in note for note in kept["walk"]["notes"])
