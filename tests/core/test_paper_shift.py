"""The paper's CoM shift on any robot (Wang et al. 2023, Sec. 5: the CoM 5 cm, or 4.3 cm,
sideways from the starting stance), measured with pinocchio's centerOfMass relative to the
first sample; whether it brings the CoM over the stance sole, from the sole's corners placed by
pinocchio; and the joints outside the legs held still during the one-leg squats."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from app.core.motions.library import SHIFT_S, SOLE_MARGIN_M, SQUAT_HALF_S, run_motion

DT = 0.02
LEGS = ("Left leg", "Right leg")


@pytest.fixture(scope="module")
def squats(robots):
    return {
        (name, shift): run_motion(robots[name], "one_leg_squats", dt=DT, shift_m=shift)
        for name in robots
        for shift in (0.05, 0.043)
    }


def sole_y_range(robot, q, side):
    """World y extent of a sole's corners at configuration q (pinocchio FK)."""
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, q)
    foot = robot.foot(side)
    placement = data.oMf[robot.model.getFrameId(foot.link)]
    ys = [(placement.rotation @ c + placement.translation)[1] for c in foot.sole_corners_m]
    return min(ys), max(ys)


@pytest.mark.parametrize("name", ["servo_biped", "roban"])
@pytest.mark.parametrize("shift", [0.05, 0.043])
def test_the_shift_is_the_papers_from_the_start_whatever_the_sole(robots, squats, name, shift):
    robot, result = robots[name], squats[name, shift]
    traj = result.trajectory
    data = robot.model.createData()
    com = np.array([pin.centerOfMass(robot.model, data, q) for q in traj.q])
    dy = com[:, 1] - com[0, 1]  # stance left: the CoM goes to +y
    shifted = traj.t >= SHIFT_S - 1e-9
    assert dy[shifted] == pytest.approx(np.full(shifted.sum(), shift), abs=2e-3)
    assert np.abs(com[:, 0] - com[0, 0]).max() < 2e-3
    low, high = sole_y_range(robot, traj.q[0], "left")
    over = low + SOLE_MARGIN_M <= com[0, 1] + shift <= high - SOLE_MARGIN_M
    said = any("cannot stand on that foot" in note for note in result.notes)
    assert said == (not over), result.notes


def test_the_5_and_4_3_cm_shifts_are_distinct_motions_on_roban(squats):
    q5 = squats["roban", 0.05].trajectory.q
    q43 = squats["roban", 0.043].trajectory.q
    assert q5.shape == q43.shape and np.abs(q5 - q43).max() > 1e-3


@pytest.mark.parametrize("shift", [0.05, 0.043])
@pytest.mark.parametrize("params", [{}, {"speed": 2.0}, {"extra_depth_m": 0.02}])
def test_squats_hold_the_joints_outside_the_legs(robots, squats, shift, params):
    """Roban S14's arms and waist (servo_biped has none): before, its squats swung arm joints
    14–21° in one sample. The squat moves the pelvis 0.1 leg lengths in SQUAT_HALF_S / speed;
    a held joint may not move more than 1 % of what a joint turning 1 rad in that time would
    move per sample, and stays within 0.1° of its start."""
    robot = robots["roban"]
    result = squats["roban", shift] if not params else None
    if result is None:
        result = run_motion(robot, "one_leg_squats", dt=DT, shift_m=shift, **params)
    held = [i for i, joint in enumerate(robot.joints) if joint.limb not in LEGS]
    assert len(held) == 9  # waist yaw, four joints per arm
    angles = np.array([robot.joint_angles(q) for q in result.trajectory.q])[:, held]
    per_sample_bound = 0.01 * 1.0 * DT * params.get("speed", 1.0) / SQUAT_HALF_S
    assert np.abs(np.diff(angles, axis=0)).max() < per_sample_bound
    assert np.abs(angles - angles[0]).max() < np.deg2rad(0.1)


def test_roban_cannot_stand_on_one_foot_at_the_papers_shift_even_on_rigid_servos(robots):
    """At 4.3 cm the CoM of Roban S14 stays short of its stance sole (checked above with the
    sole's corners): no servo can hold it on that foot, since a body standing on one foot has
    its CoM over that foot. The simulation, on near-rigid servos, must then see the robot
    fall or put its lifted foot down (carry weight on it)."""
    from app.core.servo.model import ServoModel
    from app.core.simulation.experiments import PAPER_EXPERIMENTS, run_paper_experiment

    robot = robots["roban"]
    experiment = next(e for e in PAPER_EXPERIMENTS if e.key == "squats_4.3cm")
    [row] = run_paper_experiment(
        robot, experiment, ServoModel.rigid(robot.joint_names), only=("none",)
    )
    assert any("cannot stand on that foot" in note for note in row["motion_notes"])
    assert row["verdict_kind"] in ("falls", "leans on the lifted foot"), row["verdict"]
    if row["verdict_kind"] == "leans on the lifted foot":
        assert row["lifted_foot_peak_load_frac"] > 0.05
