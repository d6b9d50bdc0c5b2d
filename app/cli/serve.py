"""`serve`: start the studio (the default command)."""

from __future__ import annotations

import argparse
import sys
import webbrowser
from pathlib import Path

from app.cli.common import (
    DEFAULTS,
    add_robot_argument,
    checked_project,
    load_robot_from_args,
    parse_feet,
)
from app.config import StudioConfig
from app.interrupts import stop_if_interrupted
from app.web.access import check_bind


def add_parser(sub) -> None:
    serve = sub.add_parser("serve")
    add_robot_argument(serve)
    serve.set_defaults(robot=None)  # to tell an explicit --robot from the default one
    serve.add_argument(
        "--project",
        type=Path,
        default=None,
        metavar="FILE",
        help="open a .bstudio project (its robot and work) instead of --robot",
    )
    serve.add_argument(
        "--fresh",
        action="store_true",
        help="start without restoring the last autosave (it is kept in the data folder)",
    )
    serve.add_argument(
        "--host", default=DEFAULTS.host, help="interface; 0.0.0.0 exposes the studio to the network"
    )
    serve.add_argument("--port", type=int, default=DEFAULTS.port)
    serve.add_argument(
        "--no-token",
        action="store_true",
        help="serve without the access token (loopback only: any program on this machine "
        "could then drive the studio)",
    )
    serve.add_argument(
        "--new-token",
        action="store_true",
        help="replace the access token kept in the data folder: links (and open tabs) from "
        "before stop working",
    )
    serve.add_argument(
        "--presenter-only",
        action="store_true",
        help="demo mode: only the first tab opened (the presenter's) can change the work; "
        "other tabs watch and can follow its camera",
    )
    serve.add_argument(
        "--open-browser", action="store_true", help="open the studio's link in the browser"
    )
    serve.add_argument(
        "--allow",
        action="append",
        default=[],
        type=Path,
        metavar="DIR",
        help="a folder whose robots *Open path* may load (repeatable; the working folder, the "
        "built-ins, --package-root folders and uploads are always allowed)",
    )


def run(args: argparse.Namespace) -> int:
    from app.studio import Studio

    explicit_robot = args.robot is not None
    args.robot = args.robot if explicit_robot else DEFAULTS.robot
    config = StudioConfig(
        robot=args.robot,
        host=args.host,
        port=args.port,
        package_roots=tuple(args.package_root),
        feet=parse_feet(args.feet),
        no_token=args.no_token,
        new_token=args.new_token,
        prepare_gait=True,
        prepare_sweep=True,
        allow=tuple(args.allow),
        project=args.project,
        presenter_only=args.presenter_only,
        restore_autosave=not (args.fresh or explicit_robot or args.project is not None),
    )
    if args.no_token and args.new_token:
        print("warning: --new-token has no effect with --no-token", file=sys.stderr)
    config, token_warning = config.settle_token()
    if token_warning:
        print(f"warning: {token_warning}", file=sys.stderr)
    elif args.new_token and not config.no_token:
        print("Made a new access token: links opened before no longer work.", file=sys.stderr)
    check_bind(config.host, config.access_token)
    if args.project is not None:  # a bad project is said before anything starts
        checked_project(args.project, tuple(args.package_root))
    robot = load_robot_from_args(args)
    if config.no_token:
        print(
            "warning: --no-token: any program running on this machine can drive the studio "
            "(web pages of other origins are still refused)",
            file=sys.stderr,
        )
    if not config.is_local:
        print(
            f"warning: serving on {config.host}: anyone who can reach this machine and has the "
            "link can use the studio and read robot files it can open",
            file=sys.stderr,
        )
    stop_if_interrupted()  # Ctrl+C swallowed while the robot loaded: stop here
    studio = Studio(config, robot)
    try:
        stop_if_interrupted()  # or while the studio started
    except KeyboardInterrupt:
        studio.stop()
        raise
    url = studio.web.url
    shown = studio.state.robot or robot
    for note in studio.project.skipped_autosaves:  # newer autosaves that failed a check
        print(f"note: {note.replace('`', '')}", file=sys.stderr)
    if studio.project.welcome:
        print(f"{studio.project.welcome} (--fresh starts without it).", flush=True)
    print(f"Biped Studio — {shown.name}. Open this link (Ctrl+C stops the studio):", flush=True)
    print(f"    {url}", flush=True)
    if args.open_browser:
        webbrowser.open(url)
    try:
        studio.web.server.sleep_forever()
    finally:
        studio.stop()
    return 0
