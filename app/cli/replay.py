"""`replay export` and `replay open`: a replay of a motion that plays in any browser, and a
local server for one."""

from __future__ import annotations

import argparse
from pathlib import Path

from app.cli.common import (
    add_coefficients_arguments,
    add_robot_argument,
    coefficients_from_args,
    load_robot_from_args,
    print_report,
)
from app.cli.motion import _params
from app.core.errors import StudioError

DEFAULT_OPEN_PORT = 8000


def add_parser(sub) -> None:
    replay = sub.add_parser("replay")
    actions = replay.add_subparsers(dest="replay_command", required=True)
    export = actions.add_parser(
        "export",
        help="record a built-in motion with its ghosts, traces and a title card into a folder",
    )
    export.add_argument(
        "--motion", required=True, help="built-in motion (biped-studio motion list)"
    )
    export.add_argument(
        "--param", action="append", default=[], metavar="NAME=VALUE", help="motion parameter"
    )
    export.add_argument("--dt", type=float, default=0.01, help="motion sample time step [s]")
    add_coefficients_arguments(
        export,
        ("uniform", "table3", "table2"),
        "compensation coefficients for the 'compensated' ghosts (default: uniform)",
        default="uniform",
    )
    export.add_argument("--fps", type=float, default=30.0, help="frames per second (≤ 60)")
    export.add_argument("--out", type=Path, required=True, help="replay folder to write")
    export.add_argument("--zip", action="store_true", help="also write OUT.zip")
    export.add_argument(
        "--force", action="store_true", help="with --zip: replace an existing OUT.zip"
    )
    export.add_argument("--json", action="store_true")
    add_robot_argument(export)
    open_ = actions.add_parser("open", help="serve a replay folder on 127.0.0.1 and print its link")
    open_.add_argument("folder", type=Path)
    open_.add_argument(
        "--port", type=int, default=DEFAULT_OPEN_PORT, help="port (0: any free port)"
    )


def run(args: argparse.Namespace) -> int:
    if args.replay_command == "open":
        return _open(args)
    return _export(args)


def _export(args: argparse.Namespace) -> int:
    from app.core.budgets import check_dt
    from app.core.motions.library import resolve_params
    from app.core.replay.folder import check_replay_target
    from app.core.replay.pipeline import headless_scene
    from app.core.replay.scene import check_frame_rate
    from app.core.simulation.files import default_servos
    from app.replay_recorder import export_replay

    check_replay_target(args.out, args.zip, args.force)  # refused before any work
    params = _params(args.param)
    resolve_params(args.motion, params)  # bad names fail before loading
    check_dt(args.dt, "--dt")
    check_frame_rate(args.fps)
    robot = load_robot_from_args(args)
    coefficients = coefficients_from_args(robot, args.preset, args.clearance, None)
    label = args.preset + (" + clearance" if args.clearance else "")
    scene = headless_scene(
        robot,
        args.motion,
        params,
        coefficients,
        default_servos(robot),
        label,
        dt=args.dt,
        frame_rate_hz=args.fps,
    )
    result = export_replay(robot, scene, args.out, make_zip=args.zip, force=args.force)
    folder = result.folder
    if args.json:
        return print_report(
            {
                "out": str(folder.path),
                "zip": None if folder.zip_path is None else str(folder.zip_path),
                "robot": robot.name,
                "motion": args.motion,
                "n_frames": result.n_frames,
                "duration_s": result.duration_s,
                "recording_bytes": folder.recording_bytes,
                "total_bytes": folder.total_bytes,
                "record_s": result.record_s,
            }
        )
    zipped = f" and {folder.zip_path}" if folder.zip_path is not None else ""
    print(
        f"replay of {args.motion} on {robot.name}: {result.n_frames} frames, "
        f"{result.duration_s:.1f} s, {folder.total_bytes / 1e6:.1f} MB -> {folder.path}{zipped} "
        f"(open it with: biped-studio replay open {folder.path})"
    )
    return 0


def _open(args: argparse.Namespace) -> int:
    from app.web.replay_server import replay_http_server

    if not 0 <= args.port <= 65535:
        raise StudioError(f"--port {args.port} is not a port number")
    try:
        httpd = replay_http_server(args.folder, args.port)
    except OSError as error:
        raise StudioError(f"cannot serve on 127.0.0.1:{args.port}: {error.strerror}") from None
    with httpd:
        port = httpd.server_address[1]
        print(f"serving {args.folder} at http://127.0.0.1:{port}/ (Ctrl+C to stop)", flush=True)
        httpd.serve_forever()
    return 0
