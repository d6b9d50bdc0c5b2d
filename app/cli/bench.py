"""The `bench` subcommand: the studio's speed targets (app.bench)."""

from __future__ import annotations

import argparse


def add_parser(sub) -> None:
    bench = sub.add_parser("bench")
    bench.add_argument(
        "--robot", default=None, help="URDF to time loading on (default: Roban S14 if found)"
    )
    bench.add_argument("--repeats", type=int, default=200)
    bench.add_argument("--json", action="store_true")
    bench.add_argument("--markdown", action="store_true", help="print docs/speed.md's table")
    bench.add_argument("--only", default="", help="comma-separated entries, e.g. drag,feedforward")
    bench.add_argument(
        "--sweep", action="store_true", help="also time a gait sweep on 1 worker and all cores"
    )


def run(args: argparse.Namespace) -> int:
    from app.bench import run_bench

    return run_bench(args)
