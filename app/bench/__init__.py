"""`biped-studio bench`: the studio's speed targets, measured on fixed work, server side.

Laid out like app/cli: one module per stage holds its entries (posing: load, slider, drag;
ik_baseline: drag_ik; playback; motions: interpolate; dynamics: feedforward; qp_solvers;
compensation: the k slider, long motions, the plots' cursor; projects; replay; sweep; gait: plan, plan_fine, plan_first_click,
plan_servo_biped; simulation: simulate, simulate_parts, simulate_click), each registered with
`@bench_entry(name)` (app.bench.registry); they run stage by stage in STAGES' order. An entry returns its raw
results and its Figures (app.bench.report), each beside a baseline doing the same work in the
same run (placo's own IK loop stopped at the studio's final error beside a drag, DAQP / ProxQP /
OSQP on the same QP, bare MuJoCo stepping the same torques beside a simulation, np.savez /
np.load beside a project file, IPOPT's defaults on the same NLP beside the gait, the core alone
beside the studio's load). The fixed pinocchio workload of `report.reference_s` runs before and
after, only to show the machine's speed held. Every time is taken through app.bench.timing.
`--only a,b` runs some entries; `--json` prints everything, `--markdown` the table of docs/speed.md.
"""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path

from app.bench import (
    compensation,
    dynamics,
    gait,
    gait_speed,
    ik_baseline,
    motions,
    playback,
    posing,
    projects,
    qp_solvers,
    registry,
    replay,
    simulation,
    sweep,
)
from app.bench.registry import OPT_IN, ROBAN_CANDIDATES, BenchContext, BenchEntry, free_port
from app.bench.report import (
    REFERENCE_WHAT,
    Figure,
    machine,
    markdown_table,
    reference_s,
    stability_line,
    text_lines,
)
from app.config import StudioConfig
from app.studio import Studio

__all__ = ["ENTRIES", "run_bench"]

STAGES = (
    posing,
    ik_baseline,
    playback,
    motions,
    dynamics,
    qp_solvers,
    compensation,
    projects,
    replay,
    sweep,
    gait,
    gait_speed,
    simulation,
)
"""The stages' modules in the order their entries run."""
ENTRIES: dict[str, BenchEntry] = {
    name: entry
    for stage in STAGES
    for name, entry in registry.ENTRIES.items()
    if entry.__module__ == stage.__name__
}
"""Every entry by name, in the order they run (a stage's in the order it registers them)."""


def run_bench(args: argparse.Namespace) -> int:
    roban = next((p for p in ROBAN_CANDIDATES if p.exists()), None)
    robot = args.robot or (str(roban) if roban else "servo_biped")
    only = [name.strip() for name in (getattr(args, "only", None) or "").split(",") if name.strip()]
    unknown = [name for name in only if name not in ENTRIES]
    if unknown:
        raise SystemExit(f"bench: unknown entries {unknown}; known: {', '.join(ENTRIES)}")
    where = machine()
    results: dict = {"machine": where}
    figures: list[Figure] = []
    with tempfile.TemporaryDirectory() as data_dir:
        studio = Studio(StudioConfig(port=free_port(), data_dir=Path(data_dir)))
        try:
            where["reference_before_s"] = reference_s()
            context = BenchContext(studio, robot, roban, args.repeats)
            for name, entry in ENTRIES.items():
                if only and name not in only:
                    continue
                if name in OPT_IN and not (getattr(args, name, False) or name in only):
                    continue
                raw, entry_figures = entry(context)
                results[name] = raw
                figures += entry_figures
            where["reference_after_s"] = reference_s()
            where["load_1min_after"] = machine()["load_1min"]
        finally:
            studio.stop()
    results["reference_what"] = REFERENCE_WHAT
    results["figures"] = [figure.as_dict() for figure in figures]
    if args.json:
        print(json.dumps(results, indent=2))
    elif getattr(args, "markdown", False):
        print(markdown_table(figures, where))
    else:
        print(
            f"{where['cpu']}, {where['cores']} cores, load {where['load_1min']:.1f}, "
            f"{where['date_utc']} UTC"
        )
        print("\n".join(text_lines(figures)))
        print(stability_line(where).strip())
    return 0
