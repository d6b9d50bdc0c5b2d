"""Issue 27's "Roban S14 stands … with servos the sizing chose", as a user runs it: `size
--servo-toml` writes the choice and the kp it chose per joint, `simulate` runs those parts.

The file is checked against the sizing's own report (each joint's choice, or the closest servo
where none holds, and its kp) and the catalogue's files (every servo one the simulation can
run); the run against the motor law's closed form (K = kt·vin·error_gain·kp/R from BAM's m1
file) and the stand check's threshold: the kp chosen for the ankles make them stiff enough to
stand, where the records' kp 32 leaves them softer than the robot needs.
"""

from __future__ import annotations

import json
import math
import re
import tomllib

import pytest

from app.core.servo.catalogue import BAM_PARAMS_DIR, SERVOS_DIR
from tests.conftest import ROBAN_URDF
from tests.test_cli import run


@pytest.fixture(scope="module")
def sized(tmp_path_factory):
    folder = tmp_path_factory.mktemp("size_then_simulate")
    motion, parts = folder / "shift.csv", folder / "servo.toml"
    made = run(
        "motion", "com_shift", "--robot", str(ROBAN_URDF), "--param", "shift_m=0.02",
        "--param", "speed=2", "--out", str(motion),
    )  # fmt: skip
    assert made.returncode == 0, made.stderr
    size = run(
        "size", str(motion), "--robot", str(ROBAN_URDF), "--servo-toml", str(parts), "--json",
    )  # fmt: skip
    assert size.returncode == 0, size.stderr
    simulated = run(
        "simulate", str(motion), "--robot", str(ROBAN_URDF), "--servo", str(parts),
        "--preset", "parts", "--json",
    )  # fmt: skip
    assert simulated.returncode == 0, simulated.stderr
    return json.loads(size.stdout), tomllib.loads(parts.read_text()), json.loads(simulated.stdout)


def _records() -> dict[str, dict]:
    return {p.stem: tomllib.loads(p.read_text()) for p in SERVOS_DIR.glob("*.toml")}


def test_the_written_file_is_the_sizings_choice_of_servos_the_simulation_runs(sized):
    report, parts, _sim = sized
    records = {data["key"]: data for data in _records().values()}
    assert "kp" not in parts  # one kp per joint, none for all
    rated = []
    for joint in report["joints"]:
        chosen = joint["chosen"] if joint["holds"] else joint["closest"]
        if chosen["stiffness_stated"]:  # rated by a continuous point: no kp law, K stated
            k = chosen["stiffness_Nm_per_rad"]
            assert k == math.ceil(chosen["stiffness_need_Nm_per_rad"]) and chosen["kp"] is None
            assert parts["joints"][joint["joint"]] == {
                "servo": chosen["servo"],
                "stiffness_Nm_per_rad": k,
            }
            record = records[chosen["servo"]]
            assert "drive" in record and "stall_torque_Nm" not in record
            rated.append(joint["joint"])
            continue
        kp = chosen["kp"] if chosen["kp"] is not None else chosen["kp_max"]
        assert parts["joints"][joint["joint"]] == {"servo": chosen["servo"], "kp": kp}
        assert joint["holds"] is False or joint["kp"] == kp
        record = records[chosen["servo"]]
        assert "firmware" in record and "identified" in record  # a motor model to run
        assert 1 <= kp <= record["firmware"]["kp_max"]
    # S14's stance joints, which no stall-rated servo holds with 30 %, get Dynamixel-P parts
    assert not report["unsized"] and rated
    assert any("no kp law for" in n for n in report["notes"])
    assert any("left out" in n and "xm540_w270" in n for n in report["notes"])


def test_s14_stays_up_on_the_sized_parts_at_their_kp(sized):
    _report, parts, sim = sized
    assert sim["verdict"].startswith("stays up"), sim["verdict"]
    assert sim["stand_check"].startswith("stands"), sim["stand_check"]
    assert sim["rms_joint_error_deg"] < 1.0
    records = {data["key"]: data for data in _records().values()}
    for row in sim["servos"]:  # K = kt·vin·error_gain·kp/R, BAM's m1 fit and the record's firmware
        record = records[row["servo"]]
        if "drive" in record:  # no kp law: the stiffness the file states
            assert row["kp"] is None
            stated = parts["joints"][row["joint"]]["stiffness_Nm_per_rad"]
            assert row["stiffness_Nm_per_rad"] == pytest.approx(stated, rel=1e-12)
            continue
        m1 = json.loads((BAM_PARAMS_DIR / record["identified"] / "m1.json").read_text())
        fw = record["firmware"]
        kp = parts["joints"][row["joint"]]["kp"]
        k = m1["kt"] * fw["vin_V"] * fw["error_gain"] * kp / m1["R"]
        assert row["kp"] == kp and row["stiffness_Nm_per_rad"] == pytest.approx(k, rel=1e-12)
    # At the records' kp 32 the ankles' parts are softer than the stand check's threshold:
    # the robot could not stand on them; the sizing's kp make them stiff enough.
    needed = float(re.search(r"needs ≤ ([0-9.]+) °/\(N·m\)", sim["stand_check"]).group(1))
    ankles = [r for r in sim["servos"] if r["joint"] in ("leg_l6_joint", "leg_r6_joint")]
    assert len(ankles) == 2
    for row in ankles:
        k = row["stiffness_Nm_per_rad"]
        assert row["compliance_deg_per_Nm"] == pytest.approx(math.degrees(1 / k), rel=1e-12)
        assert row["compliance_deg_per_Nm"] < needed
        if row["kp"] is not None:
            assert math.degrees(1 / (k * 32 / row["kp"])) > needed  # K ∝ kp


def test_compensated_commands_past_a_limit_are_clipped_and_said(sized):
    """Roban's elbows rest on their limit (0°): k·τ of the XL-320 the sizing gives them pushes
    the command past it; simulate clips it as the servo would, and says so."""
    _report, parts, sim = sized
    assert parts["joints"]["zarm_l4_joint"]["servo"] == "xl320"
    (note,) = [n for n in sim["notes"] if "clipped" in n]
    assert "zarm_" in note and "past the joint limits" in note


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--kp", "128"], "--kp goes with --servo-toml"),
        (["--servo-toml", "/nonexistent/dir/servo.toml"], "its folder does not exist"),
        (["--servo-toml", "{out}", "--kp", "-3"], "kp is -3"),
        (["--servo-toml", "{out}", "--kp", "nan"], "kp is nan"),
    ],
)
def test_bad_size_options_are_one_line(tmp_path, args, words):
    from tests.test_cli import com_shift_csv

    motion = com_shift_csv(tmp_path)
    args = [a.replace("{out}", str(tmp_path / "servo.toml")) for a in args]
    result = run("size", str(motion), *args)
    assert result.returncode == 1
    (line,) = result.stderr.strip().splitlines()
    assert words in line and "Traceback" not in result.stderr
