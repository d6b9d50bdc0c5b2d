"""What every built-in robot keeps, whatever paper its numbers come from: the committed URDF is
its builder's output (`python -m robots.build`), pinocchio finds every link's inertia physical,
and at q = 0 its sole frames are level mirror images. The robot's own numbers are checked in its
own test file (test_<robot>.py)."""

from __future__ import annotations

import pytest

from robots.build import builder_output, check_up_to_date
from robots.catalogue import BUILTIN_ROBOTS
from tests.robots.urdf_facts import (
    assert_every_inertia_physical,
    assert_soles_flat_and_symmetric,
    floating_model,
)

NAMES = tuple(BUILTIN_ROBOTS)


@pytest.mark.parametrize("name", NAMES)
def test_committed_urdf_is_the_builder_output(name):
    robot = BUILTIN_ROBOTS[name]
    committed = robot.urdf_path.read_text(encoding="utf-8")
    assert committed == builder_output(robot), "run python -m robots.build"


def test_the_build_check_finds_nothing_stale():
    assert check_up_to_date() == []


@pytest.mark.parametrize("name", NAMES)
def test_every_inertia_is_physical(name):
    path = BUILTIN_ROBOTS[name].urdf_path
    assert_every_inertia_physical(floating_model(path), path)


@pytest.mark.parametrize("name", NAMES)
def test_sole_frames_flat_and_symmetric(name):
    assert_soles_flat_and_symmetric(floating_model(BUILTIN_ROBOTS[name].urdf_path))
