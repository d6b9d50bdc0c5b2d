"""`biped-studio sweep SPEC --servo-file F.toml` as a user runs it: the files join the sweep's
servos as its `servo_files` do (repeatable, beside them), checked like every input; and the
built-in catalogue's published prices make `servo_cost` an axis without a file of one's own.

The user's servos are the built-in MX-106 under other keys, masses and prices (same motor and
firmware): each point's mass and cost are then the user's figures on every leg joint, which
shows the records reached the worker whole; the MX-106's cost is its catalogue list price."""

from __future__ import annotations

import csv
import json
import subprocess

import pytest

from app.core.servo.catalogue import load_catalogue
from tests.test_cli import run as run_cli
from tests.test_sweep_part_axes import legs, part_sweep, user_mx106

SWEEP = part_sweep(("mx106", "my106", "my107"), "servo_cost")


def run(*args: str) -> subprocess.CompletedProcess:
    return run_cli("sweep", *args, timeout_s=900)


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    folder = tmp_path_factory.mktemp("servo_file_flag")
    (folder / "sweep.toml").write_text(SWEEP)
    (folder / "a.toml").write_text(user_mx106("my106", 0.2, 99.5))
    (folder / "b.toml").write_text(user_mx106("my107", 0.3, 120.0))
    return folder


def test_servo_files_given_on_the_command_line_join_the_sweep(folder):
    out = folder / "results.csv"
    result = run(
        str(folder / "sweep.toml"), "--servo-file", str(folder / "a.toml"),
        "--servo-file", str(folder / "b.toml"), "--workers", "1", "--json", "--out", str(out),
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    rows = {row["servo"]: row for row in csv.DictReader(out.open())}
    assert set(rows) == {"mx106", "my106", "my107"}
    n = legs()
    expected = {
        "mx106": (0.153, load_catalogue()["mx106"].price),  # the catalogue's list price
        "my106": (0.2, 99.5),
        "my107": (0.3, 120.0),
    }
    for key, (mass, price) in expected.items():
        assert float(rows[key]["servo_mass_kg"]) == pytest.approx(n * mass, rel=1e-12), key
        assert float(rows[key]["servo_cost"]) == pytest.approx(n * price, rel=1e-12), key
    # the same motor and firmware: the user's servos simulate as the MX-106 they copy
    for key in ("my106", "my107"):
        assert rows[key]["solved"] == "True"
        assert float(rows[key]["electrical_energy_J"]) == pytest.approx(
            float(rows["mx106"]["electrical_energy_J"]), rel=1e-9
        )
    assert report["pareto_metrics"] == [["servo_cost", "min"], ["electrical_energy_J", "min"]]
    assert not any(n.startswith("servo_cost:") for n in report["notes"])  # every one priced


def test_without_the_flag_the_users_servo_is_unknown(folder):
    result = run(str(folder / "sweep.toml"), "--workers", "1")
    assert result.returncode == 1
    (line,) = result.stderr.strip().splitlines()
    assert "servo 'my106' is not a catalogue servo" in line


@pytest.mark.parametrize(
    ("broken", "words"),
    [
        (lambda t: t.replace("mass_kg = 0.2", "mass_kg = -0.2"), ("bad.toml", "mass_kg")),
        (lambda t: t.replace("price = 99.5", "price = nan"), ("bad.toml", "price")),
        (lambda t: t.replace('price_currency = "USD"\n', ""), ("bad.toml", "price_currency")),
        (lambda t: t.replace('key = "my106"', 'key = "mx106"'), ("bad.toml", "mx106")),
        (lambda t: "key = ", ("bad.toml", "TOML")),
    ],
)
def test_a_bad_servo_file_is_one_line_naming_the_file_and_field(folder, tmp_path, broken, words):
    bad = tmp_path / "bad.toml"
    bad.write_text(broken(user_mx106("my106", 0.2, 99.5)))
    result = run(str(folder / "sweep.toml"), "--servo-file", str(bad), "--workers", "1")
    assert result.returncode == 1 and result.stdout == ""
    (line,) = result.stderr.strip().splitlines()
    assert all(w in line for w in words), line
    assert "Traceback" not in result.stderr


def test_a_missing_servo_file_and_a_key_given_twice_are_one_line(folder, tmp_path):
    result = run(str(folder / "sweep.toml"), "--servo-file", str(tmp_path / "none.toml"))
    assert result.returncode == 1
    (line,) = result.stderr.strip().splitlines()
    assert "none.toml" in line and "--servo-file" in line
    twice = run(
        str(folder / "sweep.toml"), "--servo-file", str(folder / "a.toml"),
        "--servo-file", str(folder / "a.toml"),
    )  # fmt: skip
    assert twice.returncode == 1
    (line,) = twice.stderr.strip().splitlines()
    assert "my106" in line and "already used" in line
