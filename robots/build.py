"""Regenerate the built-in robots' URDFs from their parametric builders.

`python -m robots.build` imports `robots/<name>/build.py` for every robot of
`robots.catalogue.BUILTIN_ROBOTS`, calls its `build_urdf() -> str` and writes
`robots/<name>/<name>.urdf`. `python -m robots.build --check` writes nothing and exits non-zero
if a committed URDF differs from its builder's output (someone edited the generated file or
forgot to regenerate). A robot whose builder module does not exist yet is skipped with a note.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from robots.catalogue import BUILTIN_ROBOTS, BuiltinRobot


def has_builder(robot: BuiltinRobot) -> bool:
    """Whether `robots/<name>/build.py` exists."""
    return (robot.folder / "build.py").is_file()


def builder_output(robot: BuiltinRobot) -> str:
    """URDF text from the robot's builder (`robots.<name>.build.build_urdf()`)."""
    module = importlib.import_module(f"robots.{robot.name}.build")
    return module.build_urdf()


def regenerate_all() -> list[str]:
    """Write every built-in robot's URDF from its builder; return the names written."""
    written = []
    for robot in BUILTIN_ROBOTS.values():
        if not has_builder(robot):
            print(f"skipped {robot.name}: no builder yet ({robot.folder / 'build.py'})")
            continue
        robot.urdf_path.write_text(builder_output(robot), encoding="utf-8", newline="\n")
        print(f"wrote {robot.urdf_path}")
        written.append(robot.name)
    return written


def check_up_to_date() -> list[str]:
    """Names of the built-in robots whose committed URDF is missing or differs from the builder.

    Robots without a builder module are not checked.
    """
    stale = []
    for robot in BUILTIN_ROBOTS.values():
        if not has_builder(robot):
            continue
        path = robot.urdf_path
        if not path.is_file() or path.read_text(encoding="utf-8") != builder_output(robot):
            stale.append(robot.name)
    return stale


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m robots.build", description=__doc__)
    parser.add_argument(
        "--check", action="store_true", help="write nothing; fail if a URDF is out of date"
    )
    args = parser.parse_args(argv)
    if args.check:
        stale = check_up_to_date()
        if stale:
            print(f"out of date: {', '.join(stale)} (run python -m robots.build)")
            return 1
        print("all built-in URDFs are up to date")
        return 0
    regenerate_all()
    return 0


if __name__ == "__main__":
    sys.exit(main())
