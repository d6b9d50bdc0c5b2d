"""`sweep`: a design sweep (sweep.toml) on Dask workers, its results (CSV or Parquet) and
Pareto set."""

from __future__ import annotations

import argparse
import contextlib
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import TYPE_CHECKING

from app.cli.common import (
    add_output_arguments,
    add_paths_argument,
    output_target,
    print_report,
    written,
)
from app.core.errors import StudioError

if TYPE_CHECKING:
    from app.core.sweeps.evaluate import PointResult
    from app.core.sweeps.results import SweepSummary
    from app.core.sweeps.spec import SweepSpec
    from app.sweep_engine import SweepEngine


def add_parser(sub) -> None:
    sweep = sub.add_parser("sweep")
    sweep.add_argument("spec", type=Path, help="sweep.toml (see examples/sweep_dircon.toml)")
    sweep.add_argument(
        "--scheduler",
        default=None,
        help="Dask scheduler address tcp://HOST:PORT (default: a local cluster on this machine)",
    )
    sweep.add_argument(
        "--workers", type=int, default=None, help="local worker processes (default: one per core)"
    )
    sweep.add_argument(
        "--local-fallback",
        action="store_true",
        help="if the scheduler cannot be reached, run on a local cluster instead of failing",
    )
    add_paths_argument(
        sweep,
        "--servo-file",
        "a TOML file of your own servos (the catalogue's fields), added to the sweep's "
        "servo_files: its servos join the choices a part parameter or [part] may name "
        "(repeatable)",
        "FILE",
    )
    add_output_arguments(sweep, "results table to write: Parquet for .parquet / .pq, CSV otherwise")


def run(args: argparse.Namespace) -> int:
    from app.core.sweeps.outcomes import tally
    from app.core.sweeps.results import SweepSummary, pareto_indices, write_results

    if args.scheduler is not None and args.workers is not None:
        raise StudioError("--workers sizes the local cluster; a --scheduler has its own workers")
    spec = _read_spec(args.spec, args.servo_file)
    if args.out is not None and not args.out.resolve().parent.is_dir():
        raise StudioError(f"--out {args.out}: its folder does not exist")  # before the sweep
    start = time.perf_counter()
    engine, points = _engine_and_points(args, spec)
    with engine:
        results, first_s = _results(args, spec, engine, points, start)
        notes = list(engine.notes)
    notes += _cost_note(args, spec)
    wall = time.perf_counter() - start
    front = pareto_indices(spec, results)
    counts = tally(results, len(points), spec.simulate, finished=True)
    summary = SweepSummary(
        points=len(results),
        solved=counts.solved,
        failed=counts.failed,
        pareto=tuple(front),
        pareto_metrics=spec.pareto,
        wall_s=wall,
        points_per_s=len(results) / wall if wall > 0 else float("nan"),
        first_result_s=first_s,
    )
    if args.out is not None:
        write_results(spec, results, args.out)
    by_index = {r.index: r for r in results}
    if args.json:
        return print_report(
            {
                **summary.as_dict(),
                "parameters": [p.name for p in spec.parameters],
                "pareto_points": [by_index[i].row() for i in front],
                "notes": notes,
                "out": written(args.out),
            }
        )
    _print_front(args, spec, summary, [by_index[i] for i in front])
    return 0


def _engine_and_points(args: argparse.Namespace, spec: SweepSpec) -> tuple[SweepEngine, list]:
    """The Dask engine and the sweep's points: the cluster starts (worker processes, seconds)
    while this process samples the points (it loads the robot for its planner defaults)."""
    from app.core.sweeps.sampling import sweep_points
    from app.sweep_engine import SweepEngine

    with ThreadPoolExecutor(1, thread_name_prefix="sweep-cluster") as pool:
        starting = pool.submit(
            SweepEngine, args.scheduler, args.workers, fallback_local=args.local_fallback
        )
        try:
            points = sweep_points(spec)
        except BaseException:
            with contextlib.suppress(Exception):
                starting.result().close()
            raise
        return starting.result(), points


def _results(
    args: argparse.Namespace, spec: SweepSpec, engine: SweepEngine, points: list, start: float
) -> tuple[list[PointResult], float]:
    """The points' results as they come (each said on stderr unless --json), and the seconds
    the first one took from `start` (NaN without any)."""
    for note in engine.notes:
        print(f"note: {note}", file=sys.stderr)
    results: list[PointResult] = []
    first_s = float("nan")
    total = len(points)
    for result in engine.start(points).results():
        if not results:
            first_s = time.perf_counter() - start
        results.append(result)
        if not args.json:
            what = f"SR {result.sr:.4f}" if result.solved else result.status
            if spec.simulate and result.sim_status:
                what += f"; {result.sim_status}"
            if spec.simulate and result.sim_notes:
                what += f" (note: {result.sim_notes})"
            print(f"point {len(results)}/{total} (#{result.index}): {what}", file=sys.stderr)
    return results, first_s


def _cost_note(args: argparse.Namespace, spec: SweepSpec) -> list[str]:
    """The servo parts' cost note (said on stderr unless --json), or none."""
    if not spec.servos:
        return []
    from app.core.sweeps.part_metrics import cost_note
    from app.core.sweeps.part_parameters import offered_servos

    note = cost_note(spec.servos, offered_servos(spec.user_servos))
    if not note:
        return []
    if not args.json:
        print(f"note: {note}", file=sys.stderr)
    return [note]


def _print_front(
    args: argparse.Namespace, spec: SweepSpec, summary: SweepSummary, front: list[PointResult]
) -> None:
    """The sweep's line and its Pareto points (the parts' axes beside the two traded off)."""
    metrics = " vs ".join(f"{m} ({s})" for m, s in spec.pareto)
    print(
        f"sweep {args.spec.name}: {summary.points} points, {summary.solved} solved, "
        f"{summary.failed} failed in {summary.wall_s:.1f} s ({summary.points_per_s:.2f} "
        f"points/s, first after {summary.first_result_s:.1f} s); Pareto set of {metrics}: "
        f"{len(front)} points {list(summary.pareto)}{output_target(args.out)}"
    )
    shown_metrics = [m for m, _ in spec.pareto]
    if spec.servos:
        from app.core.sweeps.part_metrics import PART_METRICS

        shown_metrics += [m for m in PART_METRICS if m not in shown_metrics]
    for i, r in zip(summary.pareto, front, strict=True):
        values = ", ".join(
            f"{p.name} = {p.shown(v)}" for p, v in zip(spec.parameters, r.values, strict=True)
        )
        shown = ", ".join(f"{m} = {r.metric(m):.4g}" for m in shown_metrics)
        print(f"  #{i}: {values} → {shown}")


def _read_spec(path: Path, servo_files: list[Path]):
    """The sweep file checked into a SweepSpec, the --servo-file files (paths from the working
    folder) added to its own `servo_files`, every file checked as the key's are."""
    from app.core.sweeps.part_parameters import read_servo_paths
    from app.core.sweeps.spec import SweepSpec, sweep_toml_data

    data = sweep_toml_data(path)
    if servo_files:
        given = read_servo_paths(servo_files, "--servo-file")
        kept = data.get("user_servos", [])  # not a list: refused below in one line
        data["user_servos"] = [*kept, *given] if isinstance(kept, list) else kept
    return SweepSpec.from_mapping(data, str(path))
