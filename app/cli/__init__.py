"""biped-studio: the studio server and the headless commands.

Every command prints one line and exits non-zero on bad input (no traceback); `--json`
gives machine-readable output. One module per stage; `COMMANDS` maps each command to the
module that parses and runs it, imported only when that command is given: a command pays for
the libraries it uses and no other's (tests/test_cli_imports.py).
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib
import json
import sys
from collections.abc import Callable

from app.cli.common import DEFAULTS
from app.core.errors import StudioError
from app.interrupts import interrupted


@dataclasses.dataclass(frozen=True)
class Command:
    """A command of the command line: where it is built and run, and its line in `--help`."""

    module: str
    """`app.cli.<module>`: its `add_parser(sub)` adds the command's parser (and those of the
    module's other commands); imported only when the command is given."""
    help: str
    """The command's line in `biped-studio --help`."""
    run: str = "run"
    """The module's function that runs the command."""


COMMANDS: dict[str, Command] = {
    "serve": Command("serve", "start the studio (the default command)"),
    "robots": Command("robots", "list the built-in robots"),
    "check": Command("robots", "load a robot and print its report", "run_check"),
    "motion": Command(
        "motion",
        "make a built-in motion (CoM shift, one-leg squats, swings, steps) and write it as CSV",
    ),
    "bench": Command("bench", "measure the studio's speed targets"),
    "feedforward": Command(
        "feedforward",
        "joint torques of a motion CSV by the whole-body QP (LQR CoM, friction pyramids)",
    ),
    "compensate": Command(
        "compensate",
        "servo commands q + k·τ (+ φ·sign) for a motion and its torque feed-forward",
    ),
    "calibrate": Command(
        "compensate",
        "fit each servo's k from measured commands, angles and torques",
        "run_calibrate",
    ),
    "plan": Command(
        "plan",
        "plan the gait paper's symmetric walking gait (DIRCON, IPOPT) for a biped, and "
        "optionally a whole-body walk of N steps",
    ),
    "simulate": Command(
        "simulate",
        "simulate a motion on compliant servos with dead bands (MuJoCo): does it stay up?",
    ),
    "limits": Command("limits", "list every limit on files, robots, uploads and runs"),
    "replay": Command(
        "replay", "export a replay of a motion that plays in any browser, or serve one"
    ),
    "sweep": Command(
        "sweep",
        "solve a gait at every point of a sweep over robot and gait parameters (Dask), "
        "and report the Pareto set",
    ),
    "servos": Command(
        "servos", "list the servo catalogue: datasheet figures, identified models, stiffness"
    ),
    "size": Command(
        "size",
        "pick per joint the lightest (or cheapest) catalogue servo whose torque–speed "
        "envelope holds a motion's planned torques with a margin",
    ),
}
"""Every command, in the order `--help` lists them."""


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    given = argv[0] if argv and argv[0] in COMMANDS else None
    command = given or "serve"
    args: argparse.Namespace | None = None
    try:  # the command's module is imported in here: Ctrl+C while it loads is one line too
        args = _parser(given).parse_args(argv)
        command = args.command or "serve"  # plain `biped-studio` serves the default robot
        return _runner(command)(args)
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


def _module(command: str):
    return importlib.import_module(f"app.cli.{COMMANDS[command].module}")


def _runner(command: str) -> Callable[[argparse.Namespace], int]:
    return getattr(_module(command), COMMANDS[command].run)


def _parser(given: str | None) -> argparse.ArgumentParser:
    """The command line's parser: the `given` command's own (and its module's other commands'),
    every other command by its name and `--help` line only (its module is not imported)."""
    parser = argparse.ArgumentParser(prog="biped-studio", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command")
    module = None if given is None else COMMANDS[given].module
    built = False
    for name, command in COMMANDS.items():
        if command.module != module:
            sub.add_parser(name, help=command.help)
        elif not built:  # a module's commands are neighbours in COMMANDS: the order holds
            _module(name).add_parser(sub)
            built = True
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
