"""`motion` says when the paper's CoM shift cannot put a robot on one foot, and still makes
the motion: Roban S14's hips are 23.5 cm apart, so the paper's 4.3 cm leaves its CoM off the
stance sole (the sole's edge read from the URDF's corners with pinocchio)."""

from __future__ import annotations

import json

import numpy as np
import pinocchio as pin

from app.core.robot.loading import load_robot
from tests.conftest import ROBAN_URDF
from tests.test_cli import run


def test_motion_notes_that_roban_cannot_stand_at_the_papers_shift(tmp_path):
    out = tmp_path / "squats.csv"
    result = run(
        "motion", "one_leg_stand", "--robot", str(ROBAN_URDF), "--param", "shift_m=0.043",
        "--out", str(out), "--json",
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    [note] = [n for n in report["notes"] if "cannot stand on that foot" in n]
    assert "4.3 cm CoM shift" in note and "left sole" in note
    # independently: the start's CoM + 4.3 cm is short of the left sole's inner edge
    robot = load_robot(ROBAN_URDF)
    data = robot.model.createData()
    q = robot.q_neutral
    pin.framesForwardKinematics(robot.model, data, q)
    foot = robot.foot("left")
    placement = data.oMf[robot.model.getFrameId(foot.link)]
    inner = min((placement.rotation @ c + placement.translation)[1] for c in foot.sole_corners_m)
    assert pin.centerOfMass(robot.model, data, q)[1] + 0.043 < inner
    assert out.exists() and report["n_samples"] > 100 and np.isfinite(report["duration_s"])
