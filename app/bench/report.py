"""What `biped-studio bench` reports: figures beside same-run baselines, and where they ran.

A timing on a loaded or slow machine says little by itself; the same timing beside a
baseline doing the same work, measured in the same run on the same machine (placo's own IK
loop stopped at the studio's final error beside a drag event, other QP solvers on the very
same QP, bare MuJoCo stepping the same torques beside a simulation, np.savez beside a project
save, IPOPT's defaults on the same NLP beside the gait) gives a ratio that says something about
the code. `reference_s`, a fixed pinocchio workload, is timed before and after the run only to
show that the machine's speed held meanwhile: it is no figure's baseline.
"""

from __future__ import annotations

import dataclasses
import datetime
import os
import platform
import statistics
from pathlib import Path

import numpy as np

from app.bench.timing import THREAD_CPU, timed

REFERENCE_WHAT = "300 × (RNEA + CRBA + Jacobians) on servo_biped, CPU"


@dataclasses.dataclass(frozen=True)
class Figure:
    """One measured figure, its target, and its same-run baseline (lower is better for both)."""

    what: str
    value: float
    unit: str
    """Unit of value and baseline, e.g. "ms", "s"."""
    target: str
    """The target in words, e.g. "p95 ≤ 5 ms"; "" when there is none."""
    ok: bool | None
    """Whether the target is met; None when there is no target."""
    baseline: float | None
    """The baseline's figure in the same unit, measured in the same run; None when none."""
    baseline_what: str
    note: str = ""

    @classmethod
    def at_most(
        cls,
        what: str,
        value: float,
        unit: str,
        target: float,
        baseline: float | None,
        baseline_what: str,
        note: str = "",
        *,
        stat: str = "",
        met: bool = True,
    ) -> Figure:
        """A figure whose target is value ≤ `target` in `unit` ("p95 ≤ 5 ms" with `stat`
        "p95"); `met` False fails it whatever its value (a solve that did not converge)."""
        return cls(
            what,
            value,
            unit,
            f"{stat + ' ' if stat else ''}≤ {target:g} {unit}",
            met and value <= target,
            baseline,
            baseline_what,
            note,
        )

    @property
    def ratio(self) -> float | None:
        """value / baseline (how many baselines the figure costs)."""
        if self.baseline is None or self.baseline <= 0.0:
            return None
        return self.value / self.baseline

    def as_dict(self) -> dict:
        return {**dataclasses.asdict(self), "ratio": self.ratio}


def machine() -> dict:
    """Where the bench ran: CPU model, cores, load, Python, date (UTC)."""
    model = platform.processor() or platform.machine()
    cpuinfo = Path("/proc/cpuinfo")
    if cpuinfo.exists():
        for line in cpuinfo.read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    load = os.getloadavg() if hasattr(os, "getloadavg") else (float("nan"),) * 3
    return {
        "cpu": model,
        "cores": os.cpu_count() or 1,
        "load_1min": load[0],
        "python": platform.python_version(),
        "date_utc": datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M"),
    }


def reference_s(runs: int = 5) -> float:
    """Median CPU time of a fixed pinocchio workload [s], timed before and after the bench to
    show whether the machine's speed held (a stability check, never a baseline)."""
    import pinocchio as pin

    from app.core.robot.loading import load_robot

    robot = load_robot("servo_biped")
    model, data = robot.model, robot.model.createData()
    rng = np.random.default_rng(0)
    qs = [pin.randomConfiguration(model) for _ in range(300)]
    v = rng.normal(size=model.nv)

    def workload() -> None:
        for q in qs:
            pin.rnea(model, data, q, v, v)
            pin.crba(model, data, q)
            pin.computeJointJacobians(model, data, q)

    return statistics.median(timed(workload, runs, THREAD_CPU))


def _number(value: float | None) -> str:
    if value is None:
        return "—"
    return f"{value:.3g}"


def text_lines(figures: list[Figure]) -> list[str]:
    """One line per figure: value, target and mark, baseline and ratio."""
    lines = []
    for f in figures:
        mark = "" if f.ok is None else (" ok" if f.ok else " OVER TARGET")
        target = f" (target {f.target})" if f.target else ""
        base = (
            f"; baseline {_number(f.baseline)} {f.unit} ({f.baseline_what}), ratio {_number(f.ratio)}"
            if f.baseline is not None
            else ""
        )
        note = f" [{f.note}]" if f.note else ""
        lines.append(f"{f.what}: {_number(f.value)} {f.unit}{target}{mark}{base}{note}")
    return lines


def markdown_table(figures: list[Figure], where: dict) -> str:
    """The speed table of docs/speed.md: figure, target, baseline, ratio; machine and date below."""
    rows = [
        "| what | target | now | baseline (same run) | now / baseline |",
        "|---|---|---|---|---|",
    ]
    for f in figures:
        mark = "" if f.ok is None else (" ✓" if f.ok else " ✗")
        note = f" ({f.note})" if f.note else ""
        cells = (
            f.what,
            f.target or "—",
            f"{_number(f.value)} {f.unit}{mark}{note}",
            f"{_number(f.baseline)} {f.unit if f.baseline is not None else ''} {f.baseline_what}",
            _number(f.ratio),
        )
        # A "|" in a cell's text (|dq|) would end the cell: escaped as markdown wants it.
        rows.append("| " + " | ".join(cell.replace("|", "\\|") for cell in cells) + " |")
    rows.append("")
    rows.append(
        f"Machine: {where['cpu']}, {where['cores']} cores, load {where['load_1min']:.1f} at the "
        f"start{_load_after(where)}; Python {where['python']}; {where['date_utc']} UTC."
        f"{stability_line(where)}"
    )
    return "\n".join(rows)


def _load_after(where: dict) -> str:
    after = where.get("load_1min_after")
    return "" if after is None else f", {after:.1f} at the end"


def stability_line(where: dict) -> str:
    """The fixed workload before and after the run (CPU): did the machine's speed hold?"""
    before, after = where.get("reference_before_s"), where.get("reference_after_s")
    if before is None or after is None:
        return ""
    return (
        f" Machine stability: {REFERENCE_WHAT} took {before * 1e3:.1f} ms before the run and "
        f"{after * 1e3:.1f} ms after ({after / before:.2f}×); not a baseline of any figure."
    )
