"""Sweep results as CSV and as Parquet: the same columns and cells, read back independently
(the csv module, pyarrow), NaN and text with commas and quotes included."""

from __future__ import annotations

import csv
import io
import math

import pyarrow.parquet as pq
import pytest

from app.core.sweeps.evaluate import PointResult
from app.core.sweeps.results import (
    columns,
    pareto_indices,
    results_csv,
    write_results,
)
from app.core.sweeps.spec import SweepSpec

NAN = math.nan
DATA = {
    "samples": 3,
    "simulate": True,
    "pareto": {"sr": "min", "max_torso_error_deg": "min"},
    "parameter": [
        {"kind": "gait", "name": "step_length_m", "min": 0.1, "max": 0.3},
        {"kind": "servo", "name": "dead_band_deg", "min": 0.0, "max": 2.0},
    ],
}


def results() -> list[PointResult]:
    walked = PointResult(
        2, (0.1 / 3, 1.25), True, "solved", "", 0.21, 0.25, 3.2, 4.5, 1.7, 12, 0.3, 2.1, "h:1",
        fell=0.0, max_torso_error_deg=4.0, max_tracking_error_deg=2.5,
        rms_joint_error_deg=0.7, sim_status="stays up", sim_s=0.9,
    )  # fmt: skip
    fell = PointResult(
        0, (0.2, 0.5), True, "solved", "", 0.15, 0.2, 5.0, 4.0, 1.2, 20, 0.4, 0.0, "h:2",
        fell=1.0, fall_time_s=1.69, max_torso_error_deg=31.0, max_tracking_error_deg=9.0,
        rms_joint_error_deg=3.0, sim_status="falls at 1.69 s (the torso's roll, \"31°\")",
        sim_s=0.4,
    )  # fmt: skip
    unsolved = PointResult(
        1, (0.3, 2.0), False, "infeasible", "torque bound, knee", *[NAN] * 5, 40, 1.0, 0.0,
        "h:1", sim_status="not simulated: no gait",
    )  # fmt: skip
    return [walked, fell, unsolved]


def same(a: object, b: object) -> bool:
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a):
        return math.isnan(b)
    return a == b


def test_parquet_holds_the_csvs_columns_and_cells(tmp_path):
    spec = SweepSpec.from_mapping(DATA)
    csv_path, parquet_path = tmp_path / "r.csv", tmp_path / "r.parquet"
    write_results(spec, results(), csv_path)
    write_results(spec, results(), parquet_path)
    assert csv_path.read_text() == results_csv(spec, results())
    rows = list(csv.DictReader(io.StringIO(csv_path.read_text())))
    table = pq.read_table(parquet_path)
    header = ["step_length_m", "dead_band_deg", *columns(spec), "pareto"]
    assert table.column_names == header == list(rows[0])
    assert table.num_rows == len(rows) == 3
    parquet = table.to_pylist()
    for row, cells in zip(rows, parquet, strict=True):
        for name in header:
            value = cells[name]
            text = row[name]
            if isinstance(value, bool):
                assert text == str(value), name
            elif isinstance(value, float):
                assert same(value, float(text)), name  # repr round-trips a float exactly
            else:
                assert str(value) == text, name
    assert [r["index"] for r in parquet] == [0, 1, 2]  # index order, as the CSV
    front = pareto_indices(spec, results())
    assert [r["index"] for r in parquet if r["pareto"]] == front == [0, 2]
    assert table.schema.field("fell").type == table.schema.field("sr").type  # float64, NaN kept
    assert math.isnan(parquet[1]["fell"])


@pytest.mark.parametrize("suffix", [".parquet", ".PQ"])
def test_parquet_is_chosen_by_the_suffix(tmp_path, suffix):
    spec = SweepSpec.from_mapping(DATA)
    path = tmp_path / f"r{suffix}"
    write_results(spec, results(), path)
    assert path.read_bytes()[:4] == b"PAR1"
