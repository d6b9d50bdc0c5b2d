"""`limits`: every limit the studio enforces on its inputs (docs/safety.md lists them)."""

from __future__ import annotations

import argparse
import dataclasses
import json


def add_parser(sub) -> None:
    limits = sub.add_parser("limits")
    limits.add_argument("--json", action="store_true")


def run(args: argparse.Namespace) -> int:
    from app.core.safety_limits import safety_limits

    rows = safety_limits()
    if args.json:
        print(json.dumps([dataclasses.asdict(row) for row in rows], indent=2))
        return 0
    width = max(len(row.what) for row in rows)
    for row in rows:
        print(f"{row.what:{width}s}  {row.value}")
    return 0
