"""biped-studio: the studio server and the headless commands.

Every command prints one line and exits non-zero on bad input (no traceback); `--json`
gives machine-readable output.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from app.config import StudioConfig
from app.core.errors import StudioError
from robots.catalogue import BUILTIN_ROBOTS, DEFAULT_ROBOT

MAX_WARNING_LINES = 12
"""`motion` prints at most this many warning lines (grouped per keyframe) on stderr."""


def main(argv: list[str] | None = None) -> int:
    parser = _parser()
    args = parser.parse_args(argv)
    command = args.command or "serve"
    try:
        if command == "serve":
            return _serve(args)
        if command == "robots":
            return _robots(args)
        if command == "check":
            return _check(args)
        if command == "motion":
            return _motion(args)
        if command == "bench":
            from app.bench import run_bench

            return run_bench(args)
    except StudioError as error:
        if getattr(args, "json", False):
            print(json.dumps({"ok": False, "error": str(error)}))
        print(f"biped-studio {command}: {error}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:  # output piped into `head` and the like
        sys.stderr.close()
        return 0
    parser.error(f"unknown command {command}")
    return 2


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="biped-studio", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command")
    serve = sub.add_parser("serve", help="start the studio (the default command)")
    serve.add_argument("--robot", default=DEFAULT_ROBOT, help="built-in name or URDF path")
    serve.add_argument(
        "--host", default="127.0.0.1", help="interface; 0.0.0.0 exposes the studio to the network"
    )
    serve.add_argument("--port", type=int, default=8080)
    _robot_options(serve)
    robots = sub.add_parser("robots", help="list the built-in robots")
    robots.add_argument("--json", action="store_true")
    check = sub.add_parser("check", help="load a robot and print its report")
    check.add_argument("robot", help="built-in name or URDF path")
    check.add_argument("--json", action="store_true")
    _robot_options(check)
    motion = sub.add_parser(
        "motion",
        help="make a built-in motion (CoM shift, one-leg squats, swings, steps) and write it as CSV",
    )
    motion.add_argument("name", help="motion name, or 'list' to list the motions and parameters")
    motion.add_argument("--robot", default=DEFAULT_ROBOT, help="built-in name or URDF path")
    motion.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="motion parameter (repeatable); 'auto' restores a robot-scaled default",
    )
    motion.add_argument("--dt", type=float, default=0.01, help="sample time step [s]")
    motion.add_argument("--out", type=Path, default=None, help="CSV file to write")
    motion.add_argument("--json", action="store_true")
    _robot_options(motion)
    bench = sub.add_parser("bench", help="measure the studio's speed targets")
    bench.add_argument(
        "--robot", default=None, help="URDF to time loading on (default: Roban S14 if found)"
    )
    bench.add_argument("--repeats", type=int, default=200)
    bench.add_argument("--json", action="store_true")
    # Plain `biped-studio` serves the default robot.
    parser.set_defaults(
        robot=DEFAULT_ROBOT, host="127.0.0.1", port=8080, package_root=[], feet=None
    )
    return parser


def _robot_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--package-root",
        action="append",
        default=[],
        type=Path,
        help="folder holding package://NAME folders (repeatable)",
    )
    parser.add_argument(
        "--feet", default=None, help="LEFT,RIGHT foot link names, overriding detection"
    )


def _feet(value: str | None) -> tuple[str, str] | None:
    if value is None:
        return None
    names = [name.strip() for name in value.split(",")]
    if len(names) != 2 or not all(names):
        raise StudioError(f"--feet takes two link names separated by a comma, got {value!r}")
    return names[0], names[1]


def _serve(args: argparse.Namespace) -> int:
    from app.core.loading import load_robot
    from app.studio import Studio

    config = StudioConfig(
        robot=args.robot,
        host=args.host,
        port=args.port,
        package_roots=tuple(args.package_root),
        feet=_feet(args.feet),
    )
    robot = load_robot(config.robot, package_roots=config.package_roots, feet=config.feet)
    if not config.is_local:
        print(
            f"warning: serving on {config.host}: anyone who can reach this machine can use the studio "
            "and read robot files it can open",
            file=sys.stderr,
        )
    studio = Studio(config, robot)
    host = "127.0.0.1" if config.host in ("0.0.0.0", "::") else config.host
    print(
        f"Biped Studio on http://{host}:{studio.server.get_port()} — {robot.name}. Ctrl+C stops it.",
        flush=True,
    )
    try:
        studio.server.sleep_forever()
    finally:
        studio.stop()
    return 0


def _robots(args: argparse.Namespace) -> int:
    from app.core.loading import load_robot

    rows = []
    for name, entry in BUILTIN_ROBOTS.items():
        robot = load_robot(name)
        rows.append(
            {
                "name": name,
                "n_actuated": robot.n_actuated,
                "mass_kg": round(robot.mass_kg, 4),
                "default": name == DEFAULT_ROBOT,
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


def _check(args: argparse.Namespace) -> int:
    from app.core.loading import load_robot
    from app.core.report import robot_report

    robot = load_robot(args.robot, package_roots=tuple(args.package_root), feet=_feet(args.feet))
    report = robot_report(robot)
    if args.json:
        print(json.dumps(report.to_json(), indent=2))
    else:
        print("\n".join(report.lines()))
    return 0


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


def _motion(args: argparse.Namespace) -> int:
    from app.core.motions import MOTIONS, resolve_params, run_motion

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

    from app.core.loading import load_robot
    from app.core.motion_csv import write_trajectory_csv

    params = resolve_params(args.name, _params(args.param))  # bad names fail before loading
    robot = load_robot(args.robot, package_roots=tuple(args.package_root), feet=_feet(args.feet))
    result = run_motion(robot, args.name, dt=args.dt, **_params(args.param))
    traj = result.trajectory
    if args.out is not None:
        write_trajectory_csv(traj, args.out, robot)
    summary = result.summary()
    if args.json:
        report = {
            "ok": True,
            "motion": args.name,
            "robot": robot.name,
            "params": params,
            "dt_s": traj.dt,
            "duration_s": traj.duration,
            "n_samples": traj.n_samples,
            "out": None if args.out is None else str(args.out),
            "n_warnings": len(result.warnings),
            "notes": list(result.notes),
            "warnings": list(summary[len(result.notes) :]),
        }
        print(json.dumps(report, indent=2))
    else:
        target = f" -> {args.out}" if args.out is not None else " (no --out: nothing written)"
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
