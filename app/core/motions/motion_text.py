"""What every motion text file reader shares: opening through the input gate, the rows, the
numbers, and the checks an imported motion passes before it becomes a Trajectory.

The studio's own CSV format (csv_files.py) and Roban's headerless files (roban_files.py) are
read through these, so a bad cell, a zero quaternion or an unreachable configuration is named
the same way (file, line, column) whichever format it came in.
"""

from __future__ import annotations

import csv
import math
import os
from collections.abc import Iterator
from pathlib import Path
from typing import IO

import numpy as np

from app.core import input_gate
from app.core.budgets import MAX_SAMPLES
from app.core.errors import StudioError
from app.core.file_types import TextPathOrFile
from app.core.motions.trajectory import Trajectory
from app.core.robot.configurations import check_configurations, check_motion_rates
from app.core.robot.model import RobotModel


class MotionFileError(StudioError):
    """A motion file that cannot be read, or does not fit the robot."""


def open_motion(path_or_file: TextPathOrFile) -> tuple[IO[str], bool, str]:
    """(file to read, whether we opened it, name for messages); a path goes through the input
    gate (regular file, ≤ 256 MiB, UTF-8) and is streamed."""
    if isinstance(path_or_file, str | os.PathLike):
        path = Path(path_or_file)
        return input_gate.open_text(path, input_gate.MOTION_CSV, MotionFileError), True, path.name
    return path_or_file, False, str(getattr(path_or_file, "name", "motion"))


def csv_rows(file: IO[str], source: str) -> Iterator[tuple[int, list[str]]]:
    """(line number, cells) of every non-empty row (MotionFileError: more than MAX_SAMPLES + 1
    rows, or not CSV text)."""
    reader = csv.reader(file)
    count = 0
    try:
        for cells in reader:
            if cells and any(cell.strip() for cell in cells):
                count += 1
                if count > MAX_SAMPLES + 1:
                    raise MotionFileError(
                        f"{source}: more than {MAX_SAMPLES} rows; at most {MAX_SAMPLES} samples "
                        "are read (split the motion, or resample it at a larger time step)"
                    )
                yield reader.line_num, cells
    except (UnicodeDecodeError, csv.Error) as exc:
        raise MotionFileError(f"{source}: not a readable CSV text file ({exc})") from None


def cell_number(cell: str, line: int, column: int, label: str, source: str) -> float:
    """The finite number in `cell` (MotionFileError naming the line, column and its label)."""
    try:
        value = float(cell)
    except ValueError:
        raise MotionFileError(
            f"{source}, line {line}, column {column} ({label}): {cell.strip()!r} is not a number"
        ) from None
    if not math.isfinite(value):
        raise MotionFileError(
            f"{source}, line {line}, column {column} ({label}): {cell.strip()} is not a finite number"
        )
    return value


def normalised(quats: np.ndarray, lines: list[int], source: str) -> np.ndarray:
    """Quaternions (rows, 4) scaled to unit length (MotionFileError: a zero one, by its line)."""
    norms = np.linalg.norm(quats, axis=1)
    bad = np.flatnonzero(norms < 1e-9)
    if len(bad):
        raise MotionFileError(
            f"{source}, line {lines[bad[0]]}: the base quaternion is zero; it must be a rotation"
        )
    return quats / norms[:, None]


def checked(robot: RobotModel, trajectory: Trajectory, source: str) -> Trajectory:
    """`trajectory` if every sample is a configuration of `robot` with sane rates (the check
    a project gets: app.core.robot.configurations), else MotionFileError naming the sample."""
    try:
        check_configurations(robot, trajectory.q, source, t=trajectory.t)
        check_motion_rates(trajectory.v, trajectory.a, source)
    except StudioError as error:
        raise MotionFileError(str(error)) from None
    return trajectory
