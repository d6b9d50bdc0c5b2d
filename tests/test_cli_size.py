"""`biped-studio size`, run as a user runs it: a subprocess, its exit code and output."""

from __future__ import annotations

import json

import numpy as np
import pytest

from app.core.motions.csv_files import read_trajectory_csv
from app.core.robot.loading import load_robot
from app.core.servo.catalogue import load_catalogue
from app.core.servo.files import read_torque_csv
from app.core.servo.kp_sizing import MAX_SAG_DEG, STAND_MARGIN
from app.core.servo.sizing import envelope
from tests.core.test_servo_sizing import _brute_force
from tests.kp_brute_force import cheapest_pairs
from tests.test_cli import run


def _refuse(name: str) -> None:
    raise AssertionError(f"{name} in the JSON")


@pytest.fixture(scope="module")
def com_shift(tmp_path_factory):
    folder = tmp_path_factory.mktemp("size")
    motion, tau = folder / "com_shift.csv", folder / "tau.csv"
    assert run("motion", "com_shift", "--out", str(motion)).returncode == 0
    assert run("feedforward", str(motion), "--out", str(tau)).returncode == 0
    return motion, tau


def test_size_json_picks_what_a_brute_force_search_picks(com_shift):
    motion, tau_csv = com_shift
    result = run("size", str(motion), "--tau", str(tau_csv), "--margin", "0.3", "--json", "--time")
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout, parse_constant=_refuse)  # strict JSON: no Infinity
    robot = load_robot("servo_biped")
    traj = read_trajectory_csv(motion, robot)
    tau = read_torque_csv(tau_csv, robot.joint_names).tau_Nm
    w = traj.v[:, [j.idx_v for j in robot.joints]]
    servos = [
        {"key": r.key, "stall": envelope(r).stall_torque_Nm,
         "w0": envelope(r).no_load_speed_rad_s, "mass": r.mass_kg,
         "limit": envelope(r).torque_limit_Nm}
        for r in load_catalogue().values()
    ]  # fmt: skip
    by_key = {s["key"]: s for s in servos}
    expected = cheapest_pairs(
        robot, traj.q[0], tau, {s["key"]: s["mass"] for s in servos},
        lambda j, key: _brute_force(w[:, [j]], tau[:, [j]], [by_key[key]], 0.3) == [key],
    )  # fmt: skip
    assert [(row["servo"], row["kp"]) for row in report["joints"]] == expected
    assert any(kp is not None for _servo, kp in expected)  # some joints' kp chosen
    assert report["stiffness"]["stand_margin"] == STAND_MARGIN
    assert report["stiffness"]["max_sag_deg"] == MAX_SAG_DEG
    assert report["sizing_time_s"] >= 0.0
    assert any("assumed" in note for note in report["notes"])


def test_size_text_names_a_joint_no_servo_holds(com_shift, tmp_path):
    motion, tau_csv = com_shift
    heavy = tmp_path / "heavy.csv"
    lines = tau_csv.read_text().splitlines()
    header = lines[0].split(",")
    knee = header.index("tau:left_knee [N·m]") if "tau:left_knee [N·m]" in header else None
    assert knee is not None, header
    rows = [line.split(",") for line in lines[1:]]
    for row in rows:
        row[knee] = repr(150.0)  # past every servo's peak (PH54-200: 109 N·m)
    heavy.write_text("\n".join([lines[0], *(",".join(r) for r in rows)]) + "\n")
    result = run("size", str(motion), "--tau", str(heavy))
    assert result.returncode == 0, result.stderr
    (line,) = [ln for ln in result.stdout.splitlines() if "left_knee" in ln]
    assert "NO SERVO" in line and "peak" in line
    assert "11 of 12 joints sized" in result.stdout


@pytest.mark.parametrize(
    ("extra", "words"),
    [
        (("--margin", "nan"), "margin is nan"),
        (("--margin", "-0.2"), "margin is -0.2"),
        (("--robot", "no_such_robot"), "no_such_robot"),
        (("--stand-margin", "-1"), "stand margin is -1"),
        (("--max-sag-deg", "0"), "max sag is 0°"),
    ],
)
def test_hostile_options_are_one_line_and_exit_1(com_shift, extra, words):
    motion, tau_csv = com_shift
    result = run("size", str(motion), "--tau", str(tau_csv), *extra)
    assert result.returncode == 1
    (line,) = result.stderr.strip().splitlines()
    assert words in line and "Traceback" not in result.stderr


def test_an_empty_motion_is_one_line_and_exit_1(com_shift, tmp_path):
    motion, _ = com_shift
    empty = tmp_path / "empty.csv"
    empty.write_text(motion.read_text().splitlines()[0] + "\n")
    result = run("size", str(empty))
    assert result.returncode == 1
    (line,) = result.stderr.strip().splitlines()
    assert line.startswith("biped-studio size: ") and "Traceback" not in result.stderr


def test_size_of_a_project_equals_that_of_its_motion_and_torques_as_files(tmp_path):
    from app.core.dynamics.wbc import torque_feedforward
    from app.core.motions.csv_files import write_trajectory_csv
    from app.core.motions.library import run_motion
    from app.core.projects.files import save_project
    from app.core.projects.project import Project
    from app.core.projects.robot_files import robot_source
    from app.core.servo.files import write_torque_csv
    from tests.test_cli_projects import run as run_in

    robot = load_robot("servo_biped")
    motion = run_motion(robot, "com_shift", dt=0.02).trajectory
    feedforward = torque_feedforward(robot, motion)
    project = Project(
        robot=robot_source(robot), q=motion.q[0], motion=motion, feedforward=feedforward
    )
    save_project(tmp_path / "work.bstudio", project)
    write_trajectory_csv(motion, tmp_path / "motion.csv", robot)
    write_torque_csv(tmp_path / "tau.csv", feedforward)
    a = run_in(tmp_path, "size", str(tmp_path / "work.bstudio"), "--json")
    b = run_in(
        tmp_path, "size", str(tmp_path / "motion.csv"), "--tau", str(tmp_path / "tau.csv"), "--json"
    )
    assert a.returncode == 0 and b.returncode == 0, a.stderr + b.stderr
    ja, jb = json.loads(a.stdout), json.loads(b.stdout)
    assert [r["servo"] for r in ja["joints"]] == [r["servo"] for r in jb["joints"]]
    assert ja["n_samples"] == motion.n_samples


def test_size_of_a_project_holds_its_gait_too(tmp_path):
    from app.core.collocation.dircon import GaitProblem, GaitSettings, PlanarModel
    from app.core.collocation.sampling import sample_gait
    from app.core.dynamics.wbc import torque_feedforward
    from app.core.motions.library import run_motion
    from app.core.projects.files import save_project
    from app.core.projects.project import Project
    from app.core.projects.robot_files import robot_source
    from tests.test_cli_projects import run as run_in

    robot = load_robot("dircon_biped")
    motion = run_motion(robot, "com_shift", dt=0.02).trajectory
    gait = GaitProblem(PlanarModel(robot), 12, False).solve(GaitSettings(knots=12))
    assert gait.converged
    project = Project(
        robot=robot_source(robot),
        q=motion.q[0],
        motion=motion,
        feedforward=torque_feedforward(robot, motion),
        gait_symmetric=gait,
    )
    save_project(tmp_path / "work.bstudio", project)
    result = run_in(tmp_path, "size", str(tmp_path / "work.bstudio"), "--margin", "0", "--json")
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    assert report["works"] == ["motion", "symmetric gait"]
    # Each gait joint's choice holds the gait's own points (brute force, margin 0); a joint
    # no servo holds is named with its closest servo.
    samples = sample_gait(gait, np.arange(0.0, gait.duration_s, 0.01))
    catalogue = load_catalogue()
    rows = {row["joint"]: row for row in report["joints"]}
    for i, name in enumerate(gait.joint_names):
        row = rows[name]
        if row["servo"] is None:
            assert name in report["unsized"] and row["closest"]["violations"]
            continue
        r = catalogue[row["servo"]]
        env = envelope(r)
        servo = {"key": r.key, "stall": env.stall_torque_Nm, "w0": env.no_load_speed_rad_s,
                 "mass": r.mass_kg, "limit": env.torque_limit_Nm}  # fmt: skip
        w, tau = samples.v[:, [3 + i]], samples.u[:, [i]]
        assert _brute_force(w, tau, [servo], 0.0)[0] == r.key, name


def test_size_says_what_the_chosen_servos_add_up_to(com_shift):
    motion, tau_csv = com_shift
    result = run("size", str(motion), "--tau", str(tau_csv), "--json")
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    chosen = [row["servo"] for row in report["joints"] if row["servo"] is not None]
    catalogue = load_catalogue()
    total = report["totals"]
    assert total["servos"] == len(chosen)
    assert total["mass_kg"] == pytest.approx(sum(catalogue[k].mass_kg for k in chosen))
    # a chosen servo without a published list price (the MX-64's, the XL-320's were not found):
    # no price is summed, and the output says which
    unpriced = {k for k in chosen if catalogue[k].price is None}
    assert unpriced and total["price"] is None and set(total["unpriced"]) == unpriced
    text = run("size", str(motion), "--tau", str(tau_csv)).stdout
    (line,) = [line for line in text.splitlines() if line.startswith("total: ")]
    assert f"{len(chosen)} servos" in line and "price unpublished for" in line
    assert all(k in line for k in unpriced)
