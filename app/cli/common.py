"""What the headless commands share: robot options, --param pairs, output limits."""

from __future__ import annotations

import argparse
import dataclasses
import json
from pathlib import Path
from typing import TYPE_CHECKING

from app.config import StudioConfig
from app.core.errors import StudioError

if TYPE_CHECKING:  # the libraries behind them load when a command uses them, not to parse
    from app.core.dynamics.wbc import FeedForward
    from app.core.motions.trajectory import Trajectory
    from app.core.projects.project import Project
    from app.core.robot.model import RobotModel
    from app.core.servo.compensation import CompensationParams
    from app.core.servo.model import ServoModel

DEFAULTS = StudioConfig()
"""The studio's configuration defaults: the one source of the CLI's defaults."""
MAX_WARNING_LINES = 12
"""Commands print at most this many warning lines on stderr (--json lists them all)."""


def add_robot_argument(parser: argparse.ArgumentParser, default: str = DEFAULTS.robot) -> None:
    """--robot (built-in name or URDF path; `default` without it), --package-root and --feet."""
    parser.add_argument(
        "--robot", default=default, help=f"built-in name or URDF path (default {default})"
    )
    add_robot_options(parser)


def add_robot_options(parser: argparse.ArgumentParser) -> None:
    """--package-root (repeatable) and --feet."""
    add_paths_argument(
        parser, "--package-root", "folder holding package://NAME folders (repeatable)"
    )
    parser.add_argument(
        "--feet", default=None, help="LEFT,RIGHT foot link names, overriding detection"
    )


def add_motion_command(sub, name: str) -> argparse.ArgumentParser:
    """A command over a motion: `NAME TRAJECTORY` (a motion CSV or a project), --robot with
    --package-root and --feet (its line in `--help`: app.cli.COMMANDS)."""
    parser = sub.add_parser(name)
    parser.add_argument("trajectory", type=Path, help=MOTION_HELP)
    add_robot_argument(parser)
    return parser


def add_output_arguments(parser: argparse.ArgumentParser, out_help: str | None) -> None:
    """--out FILE (`out_help`; None: no file to write) and --json."""
    if out_help is not None:
        parser.add_argument("--out", type=Path, default=None, help=out_help)
    parser.add_argument("--json", action="store_true")


def add_torques_argument(parser: argparse.ArgumentParser, default: str) -> None:
    """--tau FILE: the motion's joint torques as `feedforward --out` writes them; `default`
    says where they come from without it."""
    parser.add_argument(
        "--tau",
        type=Path,
        default=None,
        help=f"torque CSV (biped-studio feedforward --out: t [s], tau:<joint> [N·m]…, status; "
        f"default: {default})",
    )


def add_coefficients_arguments(
    parser: argparse.ArgumentParser,
    presets: tuple[str, ...],
    preset_help: str,
    toml_flag: str | None = None,
    default: str | None = None,
) -> argparse._MutuallyExclusiveGroup:
    """Where the compensation coefficients come from (read by `coefficients_from_args`):
    `--preset KEY` (one of `presets`, `default` without it) with --clearance, or a k.toml
    under `toml_flag`, one or the other; the group, for another source to join it."""
    source = parser.add_mutually_exclusive_group()
    if toml_flag is not None:
        source.add_argument(
            toml_flag,
            type=Path,
            help="k.toml: [joints.<name>] k_deg_per_Nm, phi_deg, enabled (commands q + k·τ "
            "(+ φ·sign))",
        )
    source.add_argument("--preset", choices=presets, default=default, help=preset_help)
    parser.add_argument(
        "--clearance", action="store_true", help="with --preset table3: add φ = 8° (eq 23)"
    )
    return source


def add_user_servos_argument(parser: argparse.ArgumentParser) -> None:
    """--servos FILE (repeatable): the user's own servos added to the catalogue."""
    add_paths_argument(
        parser, "--servos", "a TOML file of your own servos for the catalogue (repeatable)", "FILE"
    )


def add_paths_argument(
    parser: argparse.ArgumentParser, flag: str, help: str, metavar: str | None = None
) -> None:
    """A repeatable path option: its paths in the order given (none: [])."""
    parser.add_argument(flag, action="append", default=[], type=Path, metavar=metavar, help=help)


def parse_feet(value: str | None) -> tuple[str, str] | None:
    if value is None:
        return None
    names = [name.strip() for name in value.split(",")]
    if len(names) != 2 or not all(names):
        raise StudioError(f"--feet takes two link names separated by a comma, got {value!r}")
    return names[0], names[1]


def load_robot_from_args(args: argparse.Namespace, name: str | None = None) -> RobotModel:
    """The robot named by --robot (or `name`) with --package-root and --feet."""
    from app.core.robot.loading import load_robot

    return load_robot(
        name if name is not None else args.robot,
        package_roots=tuple(args.package_root),
        feet=parse_feet(args.feet),
    )


def print_report(fields: dict[str, object]) -> int:
    """A command's --json answer, `{"ok": true, …fields}`; the exit status (0)."""
    print(json.dumps({"ok": True, **fields}, indent=2))
    return 0


def written(out: Path | None) -> str | None:
    """--out in a --json answer: the file written, or None (null) when none was."""
    return None if out is None else str(out)


def output_target(out: Path | None) -> str:
    """' -> PATH', or a note that nothing was written."""
    return f" -> {out}" if out is not None else " (no --out: nothing written)"


def coefficients_from_args(
    robot: RobotModel, preset: str | None, clearance: bool, coefficients: Path | None
) -> CompensationParams:
    """The coefficients `--preset KEY [--clearance]` or `--coeffs/--compensation k.toml` ask
    for, on the robot's joints (one registry: app.core.servo.presets.PRESETS)."""
    from app.core.servo.files import read_coefficients_toml
    from app.core.servo.presets import preset_params

    if clearance and preset != "table3":
        raise StudioError("--clearance goes with --preset table3 (a k.toml sets phi_deg itself)")
    if preset is not None:
        return preset_params("table3_clearance" if clearance else preset, robot)
    if coefficients is None:
        raise StudioError("give --preset or a k.toml of coefficients")
    return read_coefficients_toml(coefficients).for_joints(robot.joint_names)


PROJECT_SUFFIX = ".bstudio"
MOTION_HELP = (
    "motion CSV (biped-studio motion --out), or a project (.bstudio): its robot, motion, "
    "torques, coefficients and servos are the defaults of the options below"
)


@dataclasses.dataclass(frozen=True)
class MotionInputs:
    """What a headless stage reads: the robot and motion, and — from a project — the work
    done on them in the studio (None where the project has none)."""

    robot: RobotModel
    trajectory: Trajectory
    source: str
    """Where the motion came from, for messages."""
    feedforward: FeedForward | None = None
    compensation: CompensationParams | None = None
    servo: ServoModel | None = None
    compensation_torque: str = "load"
    """The torque the project's compensation multiplies ("drive" or "load",
    app.core.simulation.drive)."""


def checked_project(path: Path, package_roots: tuple[Path, ...]) -> tuple[Project, RobotModel]:
    """The project in `path` and its robot, every value checked as the studio's *Open* checks
    it (app.core.projects.project.check_fits); ProjectError (one line) otherwise."""
    from app.core.projects.files import read_project
    from app.core.projects.project import check_fits
    from app.core.projects.robot_files import load_project_robot

    project = read_project(path)
    robot = load_project_robot(project.robot, StudioConfig().uploads_dir, package_roots)
    check_fits(project, robot)
    return project, robot


def motion_inputs(args: argparse.Namespace) -> MotionInputs:
    """The robot and motion of `args.trajectory`: a motion CSV on --robot, or a project file
    (its own robot: --robot is then not used)."""
    path = Path(args.trajectory)
    if path.suffix.lower() != PROJECT_SUFFIX:
        from app.core.motions.csv_files import read_trajectory_csv

        robot = load_robot_from_args(args)
        return MotionInputs(robot, read_trajectory_csv(path, robot), str(path))
    project, robot = checked_project(path, tuple(args.package_root))
    if project.motion is None:
        raise StudioError(f"{path} holds no motion: generate or plan one in the studio and save")
    feedforward = project.feedforward
    if feedforward is not None and feedforward.tau_Nm.shape[0] != project.motion.n_samples:
        feedforward = None  # torques of an earlier motion: recomputed where they are needed
    return MotionInputs(
        robot,
        project.motion,
        str(path),
        feedforward,
        project.compensation,
        project.servo,
        project.compensation_torque,
    )
