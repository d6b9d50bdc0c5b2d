"""`robots` and `check`: the built-in robots, and the report of any robot."""

from __future__ import annotations

import argparse
import json

from app.cli.common import (
    DEFAULTS,
    add_robot_options,
    load_robot_from_args,
)
from robots.catalogue import BUILTIN_ROBOTS


def add_parser(sub) -> None:
    robots = sub.add_parser("robots")
    robots.add_argument("--json", action="store_true")
    check = sub.add_parser("check")
    check.add_argument("robot", help="built-in name or URDF path")
    check.add_argument("--json", action="store_true")
    add_robot_options(check)


def run(args: argparse.Namespace) -> int:
    from app.core.robot.loading import load_robot

    rows = []
    for name, entry in BUILTIN_ROBOTS.items():
        robot = load_robot(name)
        rows.append(
            {
                "name": name,
                "n_actuated": robot.n_actuated,
                "mass_kg": round(robot.mass_kg, 4),
                "default": name == DEFAULTS.robot,
                "summary": entry.summary,
            }
        )
    if args.json:
        print(json.dumps(rows, indent=2))
    else:
        for row in rows:
            mark = " (default)" if row["default"] else ""
            print(
                f"{row['name']:18s} {row['n_actuated']:3d} DOF {row['mass_kg']:8.3f} kg  {row['summary']}{mark}"
            )
    return 0


def run_check(args: argparse.Namespace) -> int:
    from app.core.robot.report import robot_report

    robot = load_robot_from_args(args)
    report = robot_report(robot)
    if args.json:
        print(json.dumps(report.to_json(), indent=2))
    else:
        print("\n".join(report.lines()))
    return 0
