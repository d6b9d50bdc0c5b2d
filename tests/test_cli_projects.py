"""The headless stages read a studio project (.bstudio) where they read files: the project's
robot, motion, torques and coefficients give the same results as the same inputs as files."""

from __future__ import annotations

import json
import subprocess

import numpy as np
import pytest

from app.core.dynamics.wbc import torque_feedforward
from app.core.motions.csv_files import write_trajectory_csv
from app.core.motions.library import run_motion
from app.core.projects.files import save_project
from app.core.projects.project import Project
from app.core.projects.robot_files import robot_source
from app.core.robot.loading import load_robot
from app.core.servo.files import write_torque_csv
from app.core.servo.model import joint_angles
from app.core.servo.presets import preset_params
from app.core.simulation.files import read_command_csv
from tests.test_cli import run as run_cli


def run(tmp_path, *args: str) -> subprocess.CompletedProcess:
    """The command with its data folder in `tmp_path` (projects write autosaves there)."""
    return run_cli(*args, timeout_s=300, data_dir=tmp_path / "data")


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    """servo_biped's one-leg squats, their torques and uniform coefficients: as a project and
    as the files the stages read."""
    folder = tmp_path_factory.mktemp("project")
    robot = load_robot("servo_biped")
    motion = run_motion(robot, "one_leg_squats", dt=0.02).trajectory
    feedforward = torque_feedforward(robot, motion)
    params = preset_params("uniform", robot)
    project = Project(
        robot=robot_source(robot),
        q=motion.q[0],
        motion=motion,
        feedforward=feedforward,
        compensation=params,
    )
    save_project(folder / "work.bstudio", project)
    write_trajectory_csv(motion, folder / "motion.csv", robot)
    write_torque_csv(folder / "tau.csv", feedforward)
    return folder, robot, motion


def test_feedforward_of_a_project_equals_that_of_its_motion_as_a_file(work, tmp_path):
    folder, robot, motion = work
    from_project = run(tmp_path, "feedforward", str(folder / "work.bstudio"), "--json")
    from_file = run(
        tmp_path, "feedforward", str(folder / "motion.csv"), "--robot", "servo_biped", "--json"
    )
    assert from_project.returncode == 0, from_project.stderr
    assert from_file.returncode == 0, from_file.stderr
    a, b = json.loads(from_project.stdout), json.loads(from_file.stdout)
    assert a["robot"] == robot.name and a["n_samples"] == motion.n_samples
    assert a["max_abs_tau_Nm"] == pytest.approx(b["max_abs_tau_Nm"], rel=1e-6, abs=1e-9)


def test_compensate_takes_the_projects_torques_and_coefficients(work, tmp_path):
    folder, robot, motion = work
    from_project = run(
        tmp_path, "compensate", str(folder / "work.bstudio"), "--out", str(tmp_path / "a.csv")
    )
    from_files = run(
        tmp_path,
        "compensate",
        str(folder / "motion.csv"),
        "--robot",
        "servo_biped",
        "--tau",
        str(folder / "tau.csv"),
        "--preset",
        "uniform",
        "--out",
        str(tmp_path / "b.csv"),
    )
    assert from_project.returncode == 0, from_project.stderr
    assert from_files.returncode == 0, from_files.stderr
    a = read_command_csv(tmp_path / "a.csv", robot.joint_names, motion.n_samples)
    b = read_command_csv(tmp_path / "b.csv", robot.joint_names, motion.n_samples)
    np.testing.assert_allclose(a, b, atol=1e-6)
    assert np.abs(a - joint_angles(robot, motion.q)).max() > 1e-3  # k moved joints


def test_simulate_reads_the_project_and_a_project_without_a_motion_is_refused(work, tmp_path):
    folder, robot, _motion = work
    simulated = run(tmp_path, "simulate", str(folder / "work.bstudio"), "--json")
    assert simulated.returncode == 0, simulated.stderr
    as_files = run(
        tmp_path,
        "simulate",
        str(folder / "motion.csv"),
        "--robot",
        "servo_biped",
        "--preset",
        "uniform",
        "--tau",
        str(folder / "tau.csv"),
        "--json",
    )
    assert as_files.returncode == 0, as_files.stderr
    a, b = json.loads(simulated.stdout), json.loads(as_files.stdout)
    assert a["robot"] == robot.name
    assert (a["fell"], a["verdict"]) == (b["fell"], b["verdict"])
    assert a["max_abs_pitch_deg"] == pytest.approx(b["max_abs_pitch_deg"], abs=1e-6)
    empty = tmp_path / "empty.bstudio"
    save_project(empty, Project(robot=robot_source(robot), q=robot.q_neutral))
    refused = run(tmp_path, "feedforward", str(empty))
    assert refused.returncode != 0
    assert "holds no motion" in refused.stderr and "Traceback" not in refused.stderr


def test_simulate_compensates_the_torque_the_projects_studio_chose(work, tmp_path):
    """A project whose compensation is on the drive torque (the studio's default) simulates as
    `--drive-torque` does on the same inputs as files."""
    import dataclasses

    from app.core.projects.files import read_project

    folder, _robot, _motion = work
    drive = tmp_path / "drive.bstudio"
    project = read_project(folder / "work.bstudio")
    save_project(drive, dataclasses.replace(project, compensation_torque="drive"))
    simulated = run(tmp_path, "simulate", str(drive), "--json")
    assert simulated.returncode == 0, simulated.stderr
    as_files = run(
        tmp_path, "simulate", str(folder / "motion.csv"), "--robot", "servo_biped",
        "--preset", "uniform", "--tau", str(folder / "tau.csv"), "--drive-torque", "--json",
    )  # fmt: skip
    assert as_files.returncode == 0, as_files.stderr
    a, b = json.loads(simulated.stdout), json.loads(as_files.stdout)
    assert a["label"] == b["label"] == "with compensation (drive torque)"
    assert a["max_abs_pitch_deg"] == pytest.approx(b["max_abs_pitch_deg"], abs=1e-6)
