"""biped-studio: the studio server and the headless commands.

Every command prints one line and exits non-zero on bad input (no traceback); `--json`
gives machine-readable output. One module per stage; `COMMANDS` maps each command to the
function that runs it.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable

from app.cli import (
    compensate,
    feedforward,
    limits,
    motion,
    plan,
    replay,
    robots,
    serve,
    servos,
    simulate,
    size,
    sweep,
)
from app.cli.common import DEFAULTS
from app.core.errors import StudioError
from app.interrupts import interrupted


def _bench(args: argparse.Namespace) -> int:
    from app.bench import run_bench

    return run_bench(args)


def _add_bench_parser(sub) -> None:
    bench = sub.add_parser("bench", help="measure the studio's speed targets")
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


PARSERS: tuple[Callable[..., None], ...] = (
    serve.add_parser,
    robots.add_parser,
    motion.add_parser,
    _add_bench_parser,
    feedforward.add_parser,
    compensate.add_parser,
    plan.add_parser,
    simulate.add_parser,
    limits.add_parser,
    replay.add_parser,
    sweep.add_parser,
    servos.add_parser,
    size.add_parser,
)
COMMANDS: dict[str, Callable[[argparse.Namespace], int]] = {
    "serve": serve.run,
    "robots": robots.run,
    "check": robots.run_check,
    "motion": motion.run,
    "feedforward": feedforward.run,
    "compensate": compensate.run,
    "calibrate": compensate.run_calibrate,
    "plan": plan.run,
    "simulate": simulate.run,
    "bench": _bench,
    "limits": limits.run,
    "replay": replay.run,
    "sweep": sweep.run,
    "servos": servos.run,
    "size": size.run,
}


def main(argv: list[str] | None = None) -> int:
    parser = _parser()
    args = parser.parse_args(argv)
    command = args.command or "serve"
    try:
        return COMMANDS[command](args)
    except StudioError as error:
        if getattr(args, "json", False):
            print(json.dumps({"ok": False, "error": str(error)}))
        print(f"biped-studio {command}: {error}", file=sys.stderr)
        return 1
    except MemoryError:  # a budget this code does not know yet; still one line, no traceback
        print(f"biped-studio {command}: out of memory; the input is too large", file=sys.stderr)
        return 1
    except KeyboardInterrupt:  # Ctrl+C: whatever was under way says nothing more
        print(f"biped-studio {command}: stopped (Ctrl+C)", file=sys.stderr)
        return 130
    except BrokenPipeError:  # output piped into `head` and the like
        sys.stderr.close()
        return 0
    except Exception:  # a library that turned Ctrl+C into its own error (a lazy import)
        if not interrupted():
            raise
        print(f"biped-studio {command}: stopped (Ctrl+C)", file=sys.stderr)
        return 130


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="biped-studio", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command")
    for add_parser in PARSERS:
        add_parser(sub)
    # Plain `biped-studio` serves the default robot.
    parser.set_defaults(
        robot=DEFAULTS.robot,
        host=DEFAULTS.host,
        port=DEFAULTS.port,
        package_root=[],
        feet=None,
        no_token=False,
        new_token=False,
        open_browser=False,
        allow=[],
        project=None,
        fresh=False,
        presenter_only=False,
    )
    return parser
