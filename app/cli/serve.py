"""`serve`: start the studio (the default command)."""

from __future__ import annotations

import argparse
import sys

from app.cli.common import (
    DEFAULTS,
    add_robot_argument,
    load_robot_from_args,
    parse_feet,
)
from app.config import StudioConfig


def add_parser(sub) -> None:
    serve = sub.add_parser("serve", help="start the studio (the default command)")
    add_robot_argument(serve)
    serve.add_argument(
        "--host", default=DEFAULTS.host, help="interface; 0.0.0.0 exposes the studio to the network"
    )
    serve.add_argument("--port", type=int, default=DEFAULTS.port)


def run(args: argparse.Namespace) -> int:
    from app.studio import Studio

    config = StudioConfig(
        robot=args.robot,
        host=args.host,
        port=args.port,
        package_roots=tuple(args.package_root),
        feet=parse_feet(args.feet),
    )
    robot = load_robot_from_args(args)
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
