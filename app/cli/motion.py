"""`motion`: make a built-in motion and write it as CSV."""

from __future__ import annotations

import argparse
import json
import sys

from app.cli.common import (
    MAX_WARNING_LINES,
    add_output_arguments,
    add_robot_argument,
    load_robot_from_args,
    output_target,
    print_report,
    written,
)
from app.core.budgets import check_dt
from app.core.errors import StudioError


def add_parser(sub) -> None:
    motion = sub.add_parser("motion")
    motion.add_argument("name", help="motion name, or 'list' to list the motions and parameters")
    motion.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="motion parameter (repeatable); 'auto' restores a robot-scaled default",
    )
    motion.add_argument("--dt", type=float, default=0.01, help="sample time step [s]")
    add_output_arguments(motion, "CSV file to write")
    add_robot_argument(motion)


def _params(pairs: list[str]) -> dict[str, str]:
    """--param NAME=VALUE pairs as a dict (the motion checks names and values)."""
    params: dict[str, str] = {}
    for pair in pairs:
        name, sep, value = pair.partition("=")
        name, value = name.strip(), value.strip()
        if not sep or not name or not value:
            raise StudioError(f"--param takes NAME=VALUE, got {pair!r}")
        if name in params:
            raise StudioError(f"--param {name} is given twice")
        params[name] = value
    return params


def run(args: argparse.Namespace) -> int:
    from app.core.motions.library import MOTIONS, resolve_params, run_motion

    if args.name == "list":
        if args.json:
            rows = [
                {
                    "name": spec.name,
                    "description": spec.description,
                    "params": [param.to_json() for param in spec.params],
                }
                for spec in MOTIONS.values()
            ]
            print(json.dumps(rows, indent=2))
            return 0
        for spec in MOTIONS.values():
            print(f"{spec.name:15s} {spec.description}")
            for param in spec.params:
                unit = f" [{param.unit}]" if param.unit else ""
                default = "auto" if param.default is None else param.default
                print(f"    {param.name}={default}{unit}  {param.help}")
        return 0

    from app.core.motions.csv_files import write_trajectory_csv

    params = resolve_params(args.name, _params(args.param))  # bad names fail before loading
    check_dt(args.dt, "--dt")
    robot = load_robot_from_args(args)
    result = run_motion(robot, args.name, dt=args.dt, **_params(args.param))
    traj = result.trajectory
    if args.out is not None:
        write_trajectory_csv(traj, args.out, robot)
    summary = result.summary()
    if args.json:
        return print_report(
            {
                "motion": args.name,
                "robot": robot.name,
                "params": params,
                "dt_s": traj.dt,
                "duration_s": traj.duration,
                "n_samples": traj.n_samples,
                "out": written(args.out),
                "n_warnings": len(result.warnings),
                "jump_samples": list(result.jump_samples),
                "notes": list(result.notes),
                "warnings": list(summary[len(result.notes) :]),
            }
        )
    target = output_target(args.out)
    print(
        f"{args.name} on {robot.name}: {traj.n_samples} samples, {traj.duration:.2f} s "
        f"at dt {traj.dt:g} s{target}"
    )
    for line in summary[:MAX_WARNING_LINES]:
        print(f"warning: {line}", file=sys.stderr)
    if len(summary) > MAX_WARNING_LINES:
        print(
            f"warning: … {len(summary) - MAX_WARNING_LINES} more (--json lists them all)",
            file=sys.stderr,
        )
    return 0
