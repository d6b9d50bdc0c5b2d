"""`plan`: the symmetric DIRCON gait."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from app.cli.common import (
    output_target,
)
from app.core.budgets import check_dt, check_samples
from app.core.errors import StudioError


def add_parser(sub) -> None:
    plan = sub.add_parser(
        "plan",
        help="plan the gait paper's symmetric walking gait for dircon_biped (DIRCON, IPOPT)",
    )
    plan.add_argument(
        "--config", type=Path, default=None, help="plan.toml: GaitSettings fields (K0 = 6.5, …)"
    )
    plan.add_argument(
        "--baseline", action="store_true", help="the original DIRCON planner (no symmetry)"
    )
    plan.add_argument("--out", type=Path, default=None, help="gait CSV to write (100 Hz)")
    plan.add_argument("--dt", type=float, default=0.01, help="CSV sample time step [s]")
    plan.add_argument("--json", action="store_true")


def run(args: argparse.Namespace) -> int:
    from app.core.collocation.dircon import (
        GaitProblem,
        GaitSettings,
        read_settings_toml,
        to_trajectory,
    )
    from app.core.motions.csv_files import write_trajectory_csv
    from app.core.robot.loading import load_robot

    check_dt(args.dt, "--dt")  # before the solve, not after minutes of it
    values = read_settings_toml(args.config) if args.config is not None else {}
    if args.baseline:
        values["baseline"] = True
    settings = GaitSettings.from_mapping(values, source=str(args.config or "settings"))
    check_samples(settings.H_s / args.dt + 1, 20, f"the gait CSV at --dt {args.dt:g} s")
    robot = load_robot("dircon_biped")
    problem = GaitProblem(robot, settings.knots, settings.baseline)
    result = problem.solve(settings)
    if not result.converged:  # the one-line reason, without the GUI's "last iterate" note
        raise StudioError(f"{result.status.split(';')[0]} ({result.iterations} iterations)")
    if args.out is not None:
        write_trajectory_csv(to_trajectory(robot, result, dt=args.dt), args.out, robot)
    summary = result.summary()
    if args.json:
        report = {
            "ok": True,
            **summary,
            "build_s": problem.build_s,
            "sr": result.sr,
            "out": None if args.out is None else str(args.out),
        }
        print(json.dumps(report, indent=2))
        return 0
    lsp, rsp = result.step_lengths_m
    target = output_target(args.out)
    kind = "baseline DIRCON" if settings.baseline else "symmetric"
    print(
        f"{kind} gait: {result.status} in {result.solve_s:.2f} s ({result.iterations} iterations, "
        f"built in {problem.build_s:.1f} s); max |tau| {result.max_abs_tau_Nm:.2f} N·m, "
        f"steps {lsp:.3f} / {rsp:.3f} m, slack0 {result.slack0:.3g}, SR {result.sr:.3f}{target}"
    )
    return 0
