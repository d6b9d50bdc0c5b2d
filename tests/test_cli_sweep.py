"""`biped-studio sweep` as a user runs it: a subprocess on a tiny sweep, its CSV and JSON."""

from __future__ import annotations

import csv
import json
import subprocess

import numpy as np

from tests.core.test_sweep_pareto import brute_force
from tests.test_cli import run as run_cli

TINY = """
samples = 3
seed = 2
pareto = { sr = "min", max_torque_Nm = "min" }
[gait]
knots = 14
[[parameter]]
name = "step_length_m"
min = 0.12
max = 0.28
"""


def run(*args: str) -> subprocess.CompletedProcess:
    return run_cli("sweep", *args, timeout_s=600)


def test_sweep_writes_every_point_and_the_pareto_set_of_its_rows(tmp_path):
    spec, out = tmp_path / "sweep.toml", tmp_path / "results.csv"
    spec.write_text(TINY)
    result = run(str(spec), "--workers", "2", "--out", str(out), "--json")
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    rows = list(csv.DictReader(out.open()))
    assert report["points"] == len(rows) == 3
    assert report["solved"] == sum(row["solved"] == "True" for row in rows)
    assert report["solved"] + report["failed"] == report["points"]  # every point counted once
    assert report["first_result_s"] <= report["wall_s"]
    values = np.array([[float(r["sr"]), float(r["max_torque_Nm"])] for r in rows])
    expected = {
        int(r["index"])
        for r, on in zip(rows, brute_force(values, ["min", "min"]), strict=True)
        if on
    }
    assert set(report["pareto"]) == expected
    assert {int(r["index"]) for r in rows if r["pareto"] == "1"} == expected
    for row in rows:  # the step length sampled is inside the range asked for
        assert 0.12 <= float(row["step_length_m"]) <= 0.28


def test_bad_sweep_files_and_an_unreachable_scheduler_fail_in_one_line(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(TINY.replace("samples = 3", "samples = 1000000"))
    result = run(str(bad))
    assert result.returncode == 1
    assert "limit of 20000" in result.stderr and len(result.stderr.strip().splitlines()) == 1
    good = tmp_path / "good.toml"
    good.write_text(TINY)
    result = run(str(good), "--scheduler", "tcp://127.0.0.1:9")
    assert result.returncode == 1
    assert "cannot reach the Dask scheduler" in result.stderr
    assert "Traceback" not in result.stderr


def test_sweep_writes_parquet_for_a_parquet_path(tmp_path):
    import pyarrow.parquet as pq

    spec, out = tmp_path / "sweep.toml", tmp_path / "results.parquet"
    spec.write_text(TINY.replace("samples = 3", "samples = 1"))
    result = run(str(spec), "--workers", "1", "--out", str(out), "--json")
    assert result.returncode == 0, result.stderr
    table = pq.read_table(out)
    assert table.num_rows == 1
    assert table.column_names[0] == "step_length_m" and table.column_names[-1] == "pareto"
    assert table.column("index").to_pylist() == [0]


def test_a_simulated_sweep_reports_each_points_verdict(tmp_path):
    spec, out = tmp_path / "sweep.toml", tmp_path / "results.csv"
    text = TINY.replace("samples = 3", "samples = 1\nsimulate = true\nwalk_steps = 1")
    spec.write_text(text.replace("[gait]", "[servo]\ncompensation = false\n[gait]"))
    result = run(str(spec), "--workers", "1", "--out", str(out))
    assert result.returncode == 0, result.stderr
    (row,) = list(csv.DictReader(out.open()))
    assert row["solved"] == "True"
    assert row["fell"] in ("0.0", "1.0")
    verdict = "stays up" if row["fell"] == "0.0" else "falls at"
    assert row["sim_status"].startswith(verdict)
    assert f"; {row['sim_status']}" in result.stderr  # the progress line says it too
