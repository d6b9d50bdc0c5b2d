"""A sweep's results as a table: CSV or Parquet writing and the summary (points, solved, Pareto
set). Both formats hold the same columns: the swept parameters, the metrics, and `pareto`."""

from __future__ import annotations

import csv
import dataclasses
import io
import json
from collections.abc import Sequence
from pathlib import Path
from typing import IO

import numpy as np

from app.core.atomic_write import write_atomically, write_bytes_atomically
from app.core.sweeps.evaluate import PointResult
from app.core.sweeps.outcomes import completed
from app.core.sweeps.pareto import pareto_mask
from app.core.sweeps.part_metrics import PART_METRICS
from app.core.sweeps.robot_variants import SweepSpecError
from app.core.sweeps.servo_metrics import SimulationMetrics
from app.core.sweeps.spec import SweepSpec


@dataclasses.dataclass(frozen=True, eq=False)
class SweepRecord:
    """A finished (or cancelled) sweep as a project keeps it: the spec as the user data it was
    built from (checked again by `SweepSpec.from_mapping` whenever it is read back) and the
    points' results; the Pareto front and the points are recomputed from these."""

    spec_json: str
    """The sweep's data (as `SweepSpec.from_mapping` takes it), JSON."""
    results: tuple[PointResult, ...]
    cancelled: bool = False

    def __post_init__(self) -> None:
        spec = self.spec()  # a record that does not hold a valid sweep is refused here
        width = len(spec.parameters)
        for result in self.results:
            if len(result.values) != width or not 0 <= result.index < spec.n_points:
                raise SweepSpecError(
                    f"result of point {result.index} does not fit the sweep's "
                    f"{spec.n_points} points of {width} parameters"
                )

    @classmethod
    def of(cls, data: dict, results: Sequence[PointResult], cancelled: bool = False) -> SweepRecord:
        return cls(json.dumps(data, sort_keys=True), tuple(results), cancelled)

    def spec(self) -> SweepSpec:
        try:
            data = json.loads(self.spec_json)
        except ValueError as error:
            raise SweepSpecError(f"the sweep's spec is not JSON: {error}") from None
        return SweepSpec.from_mapping(data, "the project's sweep")


PART_COLUMNS = tuple(PART_METRICS)
"""Columns of a sweep with servo parts only."""
SIMULATION_COLUMNS = tuple(
    f.name for f in dataclasses.fields(SimulationMetrics) if f.name not in PART_COLUMNS
)
"""Columns of a sweep with simulate = true only."""
COLUMNS = tuple(
    f.name
    for f in dataclasses.fields(PointResult)
    if f.name != "values" and f.name not in SIMULATION_COLUMNS + PART_COLUMNS
)
"""The metrics' columns of every sweep."""


def columns(spec: SweepSpec) -> tuple[str, ...]:
    """The result columns of this sweep (after its parameters, before `pareto`)."""
    if not spec.simulate:
        return COLUMNS
    return COLUMNS + SIMULATION_COLUMNS + (PART_COLUMNS if spec.servos else ())


def pareto_indices(spec: SweepSpec, results: Sequence[PointResult]) -> list[int]:
    """Point indices on the Pareto front of the spec's two metrics (solved points only: a point
    whose simulation failed is not one, whatever its gait's metrics)."""
    solved = [r for r in results if completed(r, spec.simulate)]
    if not solved:
        return []
    metrics = [m for m, _ in spec.pareto]
    values = np.array([[r.metric(m) for m in metrics] for r in solved])
    mask = pareto_mask(values, [s for _, s in spec.pareto])
    return sorted(r.index for r, on in zip(solved, mask, strict=True) if on)


@dataclasses.dataclass(frozen=True)
class SweepSummary:
    points: int
    """Points evaluated."""
    solved: int
    """Points with every metric asked for (a gait, and its simulation with simulate = true)."""
    failed: int
    """Points without (no gait, settings refused, the simulation or the worker failed):
    points = solved + failed (app.core.sweeps.outcomes)."""
    pareto: tuple[int, ...]
    """Indices of the Pareto-front points."""
    pareto_metrics: tuple[tuple[str, str], ...]
    wall_s: float
    """Sweep time, cluster start included [s]."""
    points_per_s: float
    first_result_s: float
    """Time from the start to the first result [s]."""
    cancelled: bool = False

    def as_dict(self) -> dict[str, object]:
        return dataclasses.asdict(self)


def results_csv(spec: SweepSpec, results: Sequence[PointResult]) -> str:
    """One row per point, in index order: the parameters (a categorical one by its choice's
    key), the metrics, and `pareto` (0/1)."""
    front = set(pareto_indices(spec, results))
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    metrics = columns(spec)
    writer.writerow([*(p.name for p in spec.parameters), *metrics, "pareto"])
    for r in sorted(results, key=lambda r: r.index):
        row = r.row()
        cells = [
            p.shown(v) if p.choices else repr(v)
            for p, v in zip(spec.parameters, r.values, strict=True)
        ]
        writer.writerow([*cells, *(row[c] for c in metrics), int(r.index in front)])
    return out.getvalue()


def results_columns(
    spec: SweepSpec, results: Sequence[PointResult]
) -> dict[str, list[float | int | bool | str]]:
    """The table column by column, rows in index order: the same cells as `results_csv`."""
    front = set(pareto_indices(spec, results))
    ordered = sorted(results, key=lambda r: r.index)
    out: dict[str, list[float | int | bool | str]] = {}
    for j, p in enumerate(spec.parameters):
        out[p.name] = [p.shown(r.values[j]) if p.choices else float(r.values[j]) for r in ordered]
    rows = [r.row() for r in ordered]
    for c in columns(spec):
        out[c] = [row[c] for row in rows]
    out["pareto"] = [int(r.index in front) for r in ordered]
    return out


def results_parquet(spec: SweepSpec, results: Sequence[PointResult]) -> bytes:
    """The results table as a Parquet file (pyarrow; floats float64, NaN where no value)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.table(results_columns(spec, results))
    sink = pa.BufferOutputStream()
    pq.write_table(table, sink)
    return bytes(sink.getvalue().to_pybytes())


PARQUET_SUFFIXES = (".parquet", ".pq")


def write_results(spec: SweepSpec, results: Sequence[PointResult], path: Path) -> None:
    """Parquet for a .parquet / .pq path, CSV otherwise."""
    if path.suffix.lower() in PARQUET_SUFFIXES:
        write_bytes_atomically(path, results_parquet(spec, results))
    else:
        write_results_csv(spec, results, path)


def write_results_csv(spec: SweepSpec, results: Sequence[PointResult], path: Path) -> None:
    text = results_csv(spec, results)

    def write(file: IO[str]) -> None:
        file.write(text)

    write_atomically(path, write)
