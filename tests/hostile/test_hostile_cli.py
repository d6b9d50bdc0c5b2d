"""Issue 15's hostile inputs against the CLI: each answered in one line, exit code 1, no
traceback, in bounded wall time (a hang detector) and peak memory ≤ 1 GB.

The files are made in the test's folder: pipes with os.mkfifo, devices are the system's own
(/dev/zero never ends, /dev/full refuses every write), chains and stars of 10 000 links."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

import pytest

from tests.conftest import tiny_biped_urdf
from tests.hostile.cli_runner import assert_refused_in_one_line, run_cli


def _fifo(tmp_path: Path, name: str) -> str:
    path = tmp_path / name
    os.mkfifo(path)
    return str(path)


def _write(tmp_path: Path, name: str, content: str | bytes) -> str:
    path = tmp_path / name
    if isinstance(content, str):
        path.write_text(content, encoding="utf-8")
    else:
        path.write_bytes(content)
    return str(path)


def _chain_urdf(n: int) -> str:
    links = "".join(
        f'<link name="l{i}"><inertial><mass value="1"/></inertial></link>' for i in range(n)
    )
    joints = "".join(
        f'<joint name="j{i}" type="revolute"><parent link="l{i}"/><child link="l{i + 1}"/>'
        '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
        for i in range(n - 1)
    )
    return f'<robot name="chain">{links}{joints}</robot>'


def _star_urdf(n: int) -> str:
    links = "".join(
        f'<link name="l{i}"><inertial><mass value="1"/></inertial></link>' for i in range(n)
    )
    joints = "".join(
        f'<joint name="j{i}" type="fixed"><parent link="l0"/><child link="l{i}"/></joint>'
        for i in range(1, n)
    )
    return f'<robot name="star">{links}{joints}</robot>'


def _tiny_with(old: str, new: str) -> str:
    text = tiny_biped_urdf()
    assert old in text
    return text.replace(old, new, 1)


def _nested_toml(depth: int) -> str:
    return "knots = " + "[" * depth + "1" + "]" * depth + "\n"


Case = Callable[[Path], list[str]]

CHECK_CASES: dict[str, tuple[Case, tuple[str, ...]]] = {
    "dev-zero": (lambda p: ["check", "/dev/zero"], ("a device",)),
    "dev-urandom": (lambda p: ["check", "/dev/urandom"], ("a device",)),
    "fifo": (lambda p: ["check", _fifo(p, "robot.urdf")], ("pipe",)),
    "chain-10000": (
        lambda p: ["check", _write(p, "chain.urdf", _chain_urdf(10_000))],
        ("10000 links", "at most 500"),
    ),
    "star-10000": (
        lambda p: ["check", _write(p, "star.urdf", _star_urdf(10_000))],
        ("10000 links", "at most 500"),
    ),
    "deep-chain-100": (
        lambda p: ["check", _write(p, "deep.urdf", _chain_urdf(100))],
        ("joints below the root", "at most 64"),
    ),
    "box-two-sizes": (
        lambda p: [
            "check",
            _write(p, "r.urdf", _tiny_with('size="0.1 0.2 0.1"', 'size="0.1 0.2"')),
        ],
        ("box has 2 size value(s)",),
    ),
    "negative-box": (
        lambda p: [
            "check",
            _write(p, "r.urdf", _tiny_with('size="0.1 0.2 0.1"', 'size="0.1 -0.2 0.1"')),
        ],
        ("size -0.2 m",),
    ),
    "zero-radius": (
        lambda p: ["check", _write(p, "r.urdf", _tiny_with('radius="0.02"', 'radius="0"'))],
        ("size 0 m",),
    ),
    "origin-1e308": (
        lambda p: ["check", _write(p, "r.urdf", _tiny_with('xyz="0 0 -0.2"', 'xyz="0 0 1e308"'))],
        ("origin xyz", "1e+308"),
    ),
    "mass-1e308": (
        lambda p: [
            "check",
            _write(p, "r.urdf", _tiny_with('mass value="2.0"', 'mass value="1e308"')),
        ],
        ("mass", "1e+308"),
    ),
    "zero-axis": (
        lambda p: ["check", _write(p, "r.urdf", _tiny_with('xyz="0 1 0"', 'xyz="0 0 0"'))],
        ("zero axis",),
    ),
    "not-utf8-no-xml": (
        lambda p: ["check", _write(p, "r.urdf", b"\xff\xfe<robot>\x00\x81")],
        ("not well-formed",),
    ),
}


@pytest.mark.parametrize("case", CHECK_CASES, ids=list(CHECK_CASES))
def test_check_refuses_in_one_line(case: str, tmp_path: Path) -> None:
    build, needles = CHECK_CASES[case]
    assert_refused_in_one_line(run_cli(*build(tmp_path), tmp_path=tmp_path), *needles)


def _plan_config(tmp_path: Path, content: str | bytes) -> list[str]:
    return ["plan", "--config", _write(tmp_path, "plan.toml", content)]


def _torque_table(tmp_path: Path, value: str) -> list[str]:
    """A one-leg stand of servo_biped and a torque CSV of `value` everywhere, for compensate."""
    from app.core.motions.csv_files import write_trajectory_csv
    from app.core.motions.library import run_motion
    from app.core.robot.loading import load_robot

    robot = load_robot("servo_biped")
    traj = run_motion(robot, "com_shift", dt=0.1).trajectory
    write_trajectory_csv(traj, tmp_path / "traj.csv", robot)
    header = ",".join(["t [s]", *(f"tau:{n} [N·m]" for n in robot.joint_names)])
    rows = [",".join([repr(float(t)), *([value] * robot.n_actuated)]) for t in traj.t]
    _write(tmp_path, "tau.csv", "\n".join([header, *rows]) + "\n")
    return [str(tmp_path / "traj.csv"), "--tau", str(tmp_path / "tau.csv")]


def _million_rows(tmp_path: Path) -> list[str]:
    """A minimal servo_biped motion CSV (no v, a columns) of a million samples, 40 MB."""
    from app.core.motions.csv_files import _columns
    from app.core.robot.loading import load_robot

    robot = load_robot("servo_biped")
    names = [name for name, _ in _columns(robot) if not name.startswith(("v:", "a:"))]
    zeros = ",".join("0" for _ in names[1:])
    path = tmp_path / "million.csv"
    with open(path, "w") as file:
        file.write(",".join(names) + "\n")
        file.writelines(f"{k / 100},{zeros}\n" for k in range(1_000_000))
    return ["feedforward", str(path)]


def _sparse(tmp_path: Path, name: str, size: int) -> str:
    path = tmp_path / name
    with open(path, "wb") as file:
        file.truncate(size)
    return str(path)


RUN_CASES: dict[str, tuple[Case, tuple[str, ...]]] = {
    "motion-dt-1e-9": (lambda p: ["motion", "com_shift", "--dt", "1e-9"], ("time step",)),
    "motion-dt-nan": (lambda p: ["motion", "com_shift", "--dt", "nan"], ("time step",)),
    "motion-speed-0.001": (
        lambda p: ["motion", "one_leg_squats", "--param", "speed=0.001"],
        ("speed", "minimum"),
    ),
    "motion-squats-1e9": (
        lambda p: ["motion", "one_leg_squats", "--param", "squats=1000000000"],
        ("squats", "maximum"),
    ),
    "motion-stride-1e308": (
        lambda p: ["motion", "step_in_place", "--param", "stride_m=1e308"],
        ("stride_m",),
    ),
    "motion-out-dev-full": (
        lambda p: ["motion", "com_shift", "--dt", "0.1", "--out", "/dev/full"],
        ("cannot write", "not a regular file"),
    ),
    "motion-out-read-only": (
        lambda p: ["motion", "com_shift", "--dt", "0.1", "--out", "/proc/motion.csv"],
        ("cannot write",),
    ),
    "plan-dt-1e-12": (lambda p: ["plan", "--dt", "1e-12"], ("--dt",)),
    "plan-knots-400": (lambda p: _plan_config(p, "knots = 400\n"), ("knots = 400", "at most")),
    "plan-toml-huge-int": (lambda p: _plan_config(p, "knots = " + "9" * 5000 + "\n"), ("plan.toml",)),
    "plan-toml-big-int": (lambda p: _plan_config(p, "knots = " + "9" * 40 + "\n"), ("too large",)),
    "plan-toml-nested-1000": (lambda p: _plan_config(p, _nested_toml(1000)), ("nested",)),
    "plan-toml-nested-30": (lambda p: _plan_config(p, _nested_toml(30)), ("nested",)),
    "plan-toml-not-utf8": (lambda p: _plan_config(p, b"knots = 38 # \xff\xfe\n"), ("not utf-8",)),
    "plan-config-dev-zero": (lambda p: ["plan", "--config", "/dev/zero"], ("a device",)),
    "plan-config-fifo": (lambda p: ["plan", "--config", _fifo(p, "plan.toml")], ("pipe",)),
    "compensate-tau-dev-zero": (
        lambda p: [
            "compensate", *_torque_table(p, "0.0"), "--tau", "/dev/zero", "--preset", "table3",
        ],
        ("a device",),
    ),
    "compensate-coeffs-dev-zero": (
        lambda p: [
            "compensate", *_torque_table(p, "0.0"), "--coeffs", "/dev/zero",
        ],
        ("a device",),
    ),
    "compensate-coeffs-fifo": (
        lambda p: [
            "compensate", *_torque_table(p, "0.0"), "--coeffs", _fifo(p, "k.toml"),
        ],
        ("pipe",),
    ),
    "compensate-tau-1e308": (
        lambda p: [
            "compensate", *_torque_table(p, "1e308"), "--preset", "table2", "--out",
            str(p / "cmd.csv"),
        ],
        ("servo command of", "at sample 0", "nothing written"),
    ),
    "calibrate-dev-zero": (lambda p: ["calibrate", "/dev/zero"], ("a device",)),
    "calibrate-fifo": (lambda p: ["calibrate", _fifo(p, "m.csv")], ("pipe",)),
    "calibrate-49MB": (
        lambda p: ["calibrate", _sparse(p, "m.csv", 49 * 2**20)],
        ("49.0 MiB", "refused"),
    ),
    "feedforward-dev-zero": (lambda p: ["feedforward", "/dev/zero"], ("a device",)),
    "feedforward-million-rows": (_million_rows, ("more than 100000 rows",)),
}  # fmt: skip


@pytest.mark.parametrize("case", RUN_CASES, ids=list(RUN_CASES))
def test_commands_refuse_in_one_line(case: str, tmp_path: Path) -> None:
    build, needles = RUN_CASES[case]
    assert_refused_in_one_line(run_cli(*build(tmp_path), tmp_path=tmp_path), *needles)
    assert not (tmp_path / "cmd.csv").exists()
