"""A sweep's results as a table: CSV writing and the summary (points, solved, Pareto set)."""

from __future__ import annotations

import csv
import dataclasses
import io
from collections.abc import Sequence
from pathlib import Path
from typing import IO

import numpy as np

from app.core.atomic_write import write_atomically
from app.core.sweeps.evaluate import PointResult
from app.core.sweeps.pareto import pareto_mask
from app.core.sweeps.spec import SweepSpec

COLUMNS = tuple(f.name for f in dataclasses.fields(PointResult) if f.name != "values")


def pareto_indices(spec: SweepSpec, results: Sequence[PointResult]) -> list[int]:
    """Point indices on the Pareto front of the spec's two metrics (solved points only)."""
    solved = [r for r in results if r.solved]
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
    """Points with a gait."""
    failed: int
    """Points whose evaluation failed (worker lost too often): not the unsolved ones."""
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
    """One row per point, in index order: the parameters, the metrics, and `pareto` (0/1)."""
    front = set(pareto_indices(spec, results))
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow([*(p.name for p in spec.parameters), *COLUMNS, "pareto"])
    for r in sorted(results, key=lambda r: r.index):
        row = r.row()
        writer.writerow(
            [*(repr(v) for v in r.values), *(row[c] for c in COLUMNS), int(r.index in front)]
        )
    return out.getvalue()


def write_results_csv(spec: SweepSpec, results: Sequence[PointResult], path: Path) -> None:
    text = results_csv(spec, results)

    def write(file: IO[str]) -> None:
        file.write(text)

    write_atomically(path, write)
