"""The headless commands, run as a user runs them: a subprocess, its exit code and output."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from robots.catalogue import BUILTIN_ROBOTS
from tests.conftest import ROBAN_URDF, tiny_biped_urdf


def run(
    *args: str, timeout_s: float = 120, data_dir: Path | None = None
) -> subprocess.CompletedProcess:
    """`python -m app ARGS` as a user runs it, its output as text; `data_dir`: the studio's
    data folder (BIPED_STUDIO_DATA) instead of the user's."""
    env = None if data_dir is None else {**os.environ, "BIPED_STUDIO_DATA": str(data_dir)}
    return subprocess.run(
        [sys.executable, "-m", "app", *args],
        capture_output=True,
        text=True,
        timeout=timeout_s,
        check=False,
        env=env,
    )


def com_shift_csv(folder: Path) -> Path:
    """`motion com_shift --out folder/com_shift.csv`, checked to succeed; the file."""
    motion = folder / "com_shift.csv"
    made = run("motion", "com_shift", "--out", str(motion))
    assert made.returncode == 0, made.stderr
    return motion


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


def test_motion_writes_csv_and_reports_json(tmp_path):
    import numpy as np
    import pinocchio as pin

    from app.core.motions.csv_files import read_trajectory_csv
    from app.core.robot.loading import load_robot

    out = tmp_path / "shift.csv"
    result = run(
        "motion", "com_shift", "--robot", "servo_biped", "--param", "shift_m=0.043",
        "--param", "side=right", "--dt", "0.02", "--out", str(out), "--json",
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    assert report["ok"] and report["motion"] == "com_shift" and report["robot"] == "servo_biped"
    assert report["params"]["shift_m"] == 0.043 and report["dt_s"] == pytest.approx(0.02)
    robot = load_robot("servo_biped")
    traj = read_trajectory_csv(out, robot)
    assert traj.n_samples == report["n_samples"] and traj.duration == report["duration_s"]
    data = robot.model.createData()
    com = [pin.centerOfMass(robot.model, data, traj.q[k]) for k in (0, -1)]
    assert com[1][1] - com[0][1] == pytest.approx(-0.043, abs=2e-3)
    assert np.all(traj.contacts)


def test_motion_bad_parameter_is_one_line_naming_the_valid_ones(tmp_path):
    result = run(
        "motion", "one_leg_squats", "--param", "depth=0.02", "--out", str(tmp_path / "x.csv")
    )
    assert result.returncode == 1 and "Traceback" not in result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "'depth'" in lines[0] and "depth_m" in lines[0]
    assert not (tmp_path / "x.csv").exists()
    result = run("motion", "moonwalk")
    assert result.returncode == 1 and "step_in_place" in result.stderr
    listed = run("motion", "list", "--json")
    assert listed.returncode == 0 and "one_leg_squats" in {
        m["name"] for m in json.loads(listed.stdout)
    }


# --- compensate / calibrate (servo spring and clearance compensation) -----------------------


def _plan_and_torques(tmp_path, drop_joint=None, amplitude_Nm=0.4, shift_m=0.05):
    """A one-leg stand of servo_biped as motion CSV, and a made-up torque CSV for it:
    τ_j(t) = amplitude·sin(t + j) N·m, every 7th sample with status 'max_iter'."""
    import math

    from app.core.motions.csv_files import write_trajectory_csv
    from app.core.motions.library import run_motion
    from app.core.robot.loading import load_robot

    robot = load_robot("servo_biped")
    traj = run_motion(robot, "one_leg_stand", dt=0.05, shift_m=shift_m).trajectory
    write_trajectory_csv(traj, tmp_path / "traj.csv", robot)
    names = [n for n in robot.joint_names if n != drop_joint]
    lines = [",".join(["t [s]", *(f"tau:{n} [N·m]" for n in names), "status"])]
    for k, t in enumerate(traj.t):
        taus = [repr(amplitude_Nm * math.sin(t + robot.joint_names.index(n))) for n in names]
        lines.append(",".join([repr(float(t)), *taus, "max_iter" if k % 7 == 0 else "ok"]))
    (tmp_path / "tau.csv").write_text("\n".join(lines) + "\n", encoding="utf-8")
    return robot, traj


def _read_columns(path):
    import csv

    with open(path, encoding="utf-8") as file:
        rows = list(csv.reader(file))
    return {name: [float(row[i]) for row in rows[1:]] for i, name in enumerate(rows[0])}


def test_compensate_refuses_commands_outside_the_joint_limits(tmp_path):
    """Table 3's k = −650 °/(N·m) times 0.4 N·m asks the hip for −260°: no file is written."""
    _plan_and_torques(tmp_path)
    out = tmp_path / "cmd.csv"
    result = run(
        "compensate", str(tmp_path / "traj.csv"), "--robot", "servo_biped",
        "--tau", str(tmp_path / "tau.csv"), "--preset", "table3", "--out", str(out),
    )  # fmt: skip
    assert result.returncode == 1
    assert "hip_pitch at sample" in result.stderr and "outside its limits" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1
    assert not out.exists() and list(tmp_path.glob(".cmd.csv*")) == []


def test_compensate_table3_with_clearance_writes_eq23_commands(tmp_path):
    import math

    # k·τ of a few degrees and a small CoM shift: the commands, φ = 8° included, stay within
    # the joint limits (otherwise nothing is written, see the test above)
    amplitude = 0.01
    robot, traj = _plan_and_torques(tmp_path, amplitude_Nm=amplitude, shift_m=0.01)
    out = tmp_path / "cmd.csv"
    result = run(
        "compensate", str(tmp_path / "traj.csv"), "--robot", "servo_biped",
        "--tau", str(tmp_path / "tau.csv"), "--preset", "table3", "--clearance",
        "--out", str(out), "--json",
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    assert {row["joint"]: row["k_deg_per_Nm"] for row in report["compensated"]} == {
        "left_hip_roll": -4.0,
        "left_hip_pitch": -650.0,
        "right_hip_roll": 20.0,
        "right_hip_pitch": -1200.0,
    }
    assert any("max_iter" in line for line in report["warnings"])
    columns = _read_columns(out)
    assert columns["t [s]"] == pytest.approx(list(traj.t))
    k = {"left_hip_roll": -4.0, "left_hip_pitch": -650.0, "left_knee": 0.0}
    for name, k_j in k.items():
        j = robot.joint_names.index(name)
        for i, t in enumerate(traj.t):
            q_deg = math.degrees(traj.q[i, robot.joints[j].idx_q])
            spring = q_deg + k_j * amplitude * math.sin(t + j)  # eq 7
            expected = spring + (8.0 * math.copysign(1.0, spring) if k_j else 0.0)  # eq 23
            assert columns[f"q_cmd:{name} [deg]"][i] == pytest.approx(expected, abs=1e-9)
            assert columns[f"q_cmd:{name} [rad]"][i] == pytest.approx(
                math.radians(expected), abs=1e-11
            )


def test_compensate_with_a_coefficient_file(tmp_path):
    _plan_and_torques(tmp_path)
    coeffs = tmp_path / "k.toml"
    coeffs.write_text(
        "[joints.right_knee]\nk_deg_per_Nm = 2.5\n[joints.left_knee]\nk_deg_per_Nm = 1\n"
        "enabled = false\n"
    )
    result = run(
        "compensate", str(tmp_path / "traj.csv"), "--tau", str(tmp_path / "tau.csv"),
        "--coeffs", str(coeffs), "--json",
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    (row,) = json.loads(result.stdout)["compensated"]
    assert row["joint"] == "right_knee" and row["k_deg_per_Nm"] == 2.5
    assert row["max_correction_deg"] == pytest.approx(2.5 * 0.4, rel=0.05)


@pytest.mark.parametrize(
    "extra, drop, message",
    [
        (("--preset", "table3"), "left_knee", "no tau:<joint> column for left_knee"),
        (("--coeffs", "k.toml", "--clearance"), None, "--clearance goes with --preset table3"),
        (("--preset", "table2", "--robot", "dircon_biped"), None, "unknown column"),
    ],
)
def test_compensate_bad_input_is_one_line(tmp_path, extra, drop, message):
    _plan_and_torques(tmp_path, drop_joint=drop)
    (tmp_path / "k.toml").write_text("[joints.left_knee]\nk_deg_per_Nm = 1\n")
    extra = tuple(str(tmp_path / e) if e == "k.toml" else e for e in extra)
    result = run(
        "compensate", str(tmp_path / "traj.csv"), "--tau", str(tmp_path / "tau.csv"), *extra
    )
    assert result.returncode == 1 and "Traceback" not in result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0]


def test_calibrate_json_on_the_papers_table2(tmp_path):
    rows = [  # Table 2: servo, q_des [°], q [°], τ [N·m]
        (2, 0.6226, 0.15625, -0.36474),
        (4, 68.7407, 71.6406, -1.86625),
        (11, -30.8266, -29.375, 0.02008),
    ]
    lines = ["frame,joint,q_cmd_deg,q_meas_deg,tau_Nm"]
    lines += [f"0,servo{s},{q_des},{q},{tau}" for s, q_des, q, tau in rows]
    lines += [f"{f},idle,{f},{f},0" for f in range(3)]
    path = tmp_path / "measured.csv"
    path.write_text("\n".join(lines) + "\n")
    result = run("calibrate", str(path), "--json")
    assert result.returncode == 0, result.stderr
    out = {row["joint"]: row for row in json.loads(result.stdout)}
    assert out["servo2"]["k_deg_per_Nm"] == pytest.approx(-1.28, abs=0.005)
    assert out["servo4"]["k_deg_per_Nm"] == pytest.approx(1.55, abs=0.005)
    assert out["servo11"]["k_deg_per_Nm"] == pytest.approx(-72.29, abs=0.005)  # not −722.91
    assert out["servo4"]["identifiable"] and out["servo4"]["se_deg_per_Nm"] is None
    assert not out["servo11"]["identifiable"] and "N·m" in out["servo11"]["reason"]
    assert not out["idle"]["identifiable"] and out["idle"]["k_deg_per_Nm"] is None
    text = run("calibrate", str(path))
    assert text.returncode == 0 and "servo4" in text.stdout and "NOT identifiable" in text.stdout


def test_calibrate_malformed_file_names_the_line(tmp_path):
    path = tmp_path / "measured.csv"
    path.write_text("frame,joint,q_cmd_deg,q_meas_deg,tau_Nm\n0,knee,1,0,2\n1,knee,one,0,2\n")
    result = run("calibrate", str(path))
    assert result.returncode == 1
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "line 3" in lines[0] and "'one'" in lines[0]


# --- feedforward (whole-body QP torques) -----------------------------------------------------


def test_feedforward_writes_torque_csv_and_reports_json(tmp_path):
    import csv

    import numpy as np

    from app.core.motions.csv_files import read_trajectory_csv
    from app.core.robot.loading import load_robot

    motion = tmp_path / "shift.csv"
    made = run("motion", "com_shift", "--dt", "0.05", "--out", str(motion))
    assert made.returncode == 0, made.stderr
    out = tmp_path / "tau.csv"
    result = run("feedforward", str(motion), "--robot", "servo_biped", "--out", str(out), "--json")
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    robot = load_robot("servo_biped")
    traj = read_trajectory_csv(motion, robot)
    assert report["ok"] and report["n_samples"] == traj.n_samples
    assert report["infeasible_samples"] == [] and report["solve_time_s"] > 0.0
    with open(out, encoding="utf-8") as file:
        rows = list(csv.reader(file))
    assert rows[0] == ["t [s]", *(f"tau:{n} [N·m]" for n in robot.joint_names), "status"]
    assert len(rows) == traj.n_samples + 1 and {row[-1] for row in rows[1:]} == {"solved"}
    tau = np.array([[float(x) for x in row[1:-1]] for row in rows[1:]])
    peaks = np.abs(tau).max(axis=0)
    assert report["max_abs_tau_Nm"] == pytest.approx(
        dict(zip(robot.joint_names, peaks, strict=True))
    )
    # nothing flagged in a slow CoM shift: the peaks over all samples are the same
    assert report["flagged_samples"] == {"infeasible": [], "over_speed": []}
    assert report["max_abs_tau_all_samples_Nm"] == report["max_abs_tau_Nm"]
    # the file holds the library's torques (repr round trip); their physics is checked in
    # tests/core/test_wbc.py. Not bit for bit: the QP solver's vectorised sums depend on
    # where the arrays lie in memory, which differs between this process and the command's.
    from app.core.dynamics.wbc import torque_feedforward

    here = torque_feedforward(robot, traj).tau_Nm
    np.testing.assert_allclose(tau, here, rtol=0.0, atol=1e-9 * np.abs(here).max())


def test_feedforward_over_worker_processes_gives_the_same_torques(tmp_path):
    import numpy as np

    motion = tmp_path / "shift.csv"
    assert run("motion", "com_shift", "--dt", "0.02", "--out", str(motion)).returncode == 0
    files = {}
    for workers in ("1", "2"):
        files[workers] = tmp_path / f"tau{workers}.csv"
        result = run("feedforward", str(motion), "--out", str(files[workers]), "--workers", workers)
        assert result.returncode == 0, result.stderr

    def read(path):
        rows = [line.split(",") for line in path.read_text(encoding="utf-8").splitlines()[1:]]
        return np.array([[float(x) for x in row[1:-1]] for row in rows]), [row[-1] for row in rows]

    (serial, status1), (parallel, status2) = read(files["1"]), read(files["2"])
    assert status1 == status2
    assert np.abs(serial - parallel).max() <= 1e-9 * np.abs(serial).max()  # round-off only
    bad = run("feedforward", str(motion), "--workers", "-1")
    assert bad.returncode != 0 and "--workers" in bad.stderr and len(bad.stderr.splitlines()) == 1


def test_feedforward_on_a_motion_of_another_robot_is_one_line(tmp_path):
    motion = tmp_path / "shift.csv"
    assert run("motion", "com_shift", "--dt", "0.1", "--out", str(motion)).returncode == 0
    result = run("feedforward", str(motion), "--robot", "dircon_biped")
    assert result.returncode == 1 and "Traceback" not in result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "unknown column" in lines[0]


def test_plan_writes_a_gait_csv_and_reports_json(tmp_path):
    import numpy as np

    from app.core.motions.csv_files import read_trajectory_csv
    from app.core.robot.loading import load_robot

    config = tmp_path / "plan.toml"
    config.write_text("knots = 12\nK0 = 6.5\n")
    out = tmp_path / "gait.csv"
    result = run("plan", "--config", str(config), "--out", str(out), "--json")
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    for key in (
        "status",
        "solve_s",
        "iterations",
        "max_abs_tau_Nm",
        "step_lengths_m",
        "slack0",
        "sr",
    ):
        assert key in report
    assert report["ok"] is True and report["status"] == "solved"
    assert report["max_abs_tau_Nm"] <= 13.0 + 1e-6  # the paper's |τ| ≤ 13 N·m
    assert sum(report["step_lengths_m"]) == pytest.approx(0.2)  # two steps advance 0.2 m
    traj = read_trajectory_csv(out, load_robot("dircon_biped"))
    assert traj.dt == pytest.approx(0.01) and traj.duration == pytest.approx(0.72)
    assert traj.q[-1, 0] - traj.q[0, 0] == pytest.approx(0.2)
    assert np.all(traj.contacts.sum(axis=1) == 1)  # single support, feet taking turns


@pytest.mark.parametrize(
    "config, reason",
    [
        ("knots = 12\nslack_a = 0.05\nslack_b = -0.05\n", "slack bounds crossed"),
        # IPOPT either proves local infeasibility or runs out of iterations: both refuse.
        ("knots = 12\ntau_max_Nm = 0.1\nmax_iter = 300\n", ("admit no gait", "not converged")),
        ("K3 = 1.0\n", "unknown key"),
    ],
)
def test_plan_refuses_bad_settings_with_one_line(tmp_path, config, reason):
    path = tmp_path / "plan.toml"
    path.write_text(config)
    result = run("plan", "--config", str(path), "--out", str(tmp_path / "gait.csv"))
    assert result.returncode == 1 and "Traceback" not in result.stderr
    lines = result.stderr.strip().splitlines()
    reasons = (reason,) if isinstance(reason, str) else reason
    assert len(lines) == 1 and any(r in lines[0] for r in reasons)
    assert not (tmp_path / "gait.csv").exists()


def test_limits_lists_what_the_gate_enforces(tmp_path):
    """`limits` names the URDF size limit, and a file one byte over it is refused with the
    same number."""
    import importlib

    result = run("limits", "--json")
    assert result.returncode == 0, result.stderr
    rows = {row["what"]: row for row in json.loads(result.stdout)}
    for row in rows.values():
        importlib.import_module(row["where"])
    assert rows["URDF file size"]["value"] == "20 MiB"
    big = tmp_path / "big.urdf"
    with open(big, "wb") as file:
        file.truncate(20 * 2**20 + 1)
    refused = run("check", str(big))
    assert refused.returncode == 1 and "over 20.0 MiB" in refused.stderr


def test_plan_walks_servo_biped_several_steps(tmp_path):
    import numpy as np

    from app.core.motions.csv_files import read_trajectory_csv
    from app.core.robot.loading import load_robot

    out = tmp_path / "walk.csv"
    config = tmp_path / "plan.toml"
    config.write_text("max_iter = 300\n")
    result = run(
        "plan", "--robot", "servo_biped", "--config", str(config), "--steps", "3",
        "--out", str(out), "--json",
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    assert report["robot"] == "servo_biped" and report["walk"]["steps"] == 3
    assert len(report["walk"]["footprints"]) == 2 + 3
    traj = read_trajectory_csv(out, load_robot("servo_biped"))
    assert traj.contacts[0].all() and traj.contacts[-1].all()  # from standing to standing
    assert np.any(traj.contacts.sum(axis=1) == 1)
    assert traj.q[-1, 0] > traj.q[0, 0]  # it went forwards


def test_plan_refuses_a_robot_it_cannot_plan_for_in_one_line(tmp_path):
    urdf = tmp_path / "tiny.urdf"
    urdf.write_text(tiny_biped_urdf())  # hip pitch and knee only: no ankle pitch
    result = run("plan", "--robot", str(urdf))
    assert result.returncode == 1 and "Traceback" not in result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "pitch joint" in lines[0]


def test_plan_that_finds_no_gait_names_the_bound_and_where_it_is_set(tmp_path):
    """A torque bound far below what walking needs (0.1 N·m for an 18.5 kg robot): the one
    line names the torque bound, not only IPOPT's status."""
    path = tmp_path / "plan.toml"
    path.write_text("knots = 12\ntau_max_Nm = 0.1\nmax_iter = 300\n")
    result = run("plan", "--config", str(path))
    assert result.returncode == 1 and "Traceback" not in result.stderr
    line = result.stderr.strip()
    assert len(line.splitlines()) == 1 and "torque bound |τ| ≤ 0.1 N·m" in line
