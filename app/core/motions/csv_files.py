"""Motions as CSV files: the studio's own self-describing format (Roban's headerless motion
files: roban_files.py, whose names this module also gives).

The studio's format has ONE header row naming every column with its joint and unit, then one
row per sample, numbers written with Python's `repr` (shortest text that reads back to the
same float, so a round trip is exact). Columns, for a floating-base robot:

    t [s]
    base_x [m], base_y [m], base_z [m]          base position in the world
    base_qx, base_qy, base_qz, base_qw          base orientation, quaternion in xyzw order
    q:<joint> [rad]   (or [m] if prismatic)     every moving joint of the model: the actuated
                                                joints in the robot's order, then the passive
                                                joints of closed loops, so q is recoverable;
                                                a continuous joint is written as an angle
    v:base_vx … v:base_vz [m/s], v:base_wx … v:base_wz [rad/s], v:<joint> [rad/s or m/s]
    a:base_vx … a:base_vz [m/s^2], a:base_wx … a:base_wz [rad/s^2], a:<joint> [rad/s^2 or m/s^2]
    contact_left [0/1], contact_right [0/1]

`a:X` is the time derivative of `v:X`. Base velocities and accelerations are pinocchio's: the
base twist expressed in the base frame. A fixed-base robot has no base columns. The reader
takes the columns in any order; the v and a columns may be left out together, and are then
computed from the configurations by finite differences (trajectory.from_configurations).
Times must be evenly spaced; they are shifted so that the first sample is at t = 0.
"""

from __future__ import annotations

import csv
import dataclasses
import math
import os
import re
from collections.abc import Iterator
from pathlib import Path
from typing import IO

import numpy as np

from app.core.atomic_write import write_atomically
from app.core.file_types import TextPathOrFile
from app.core.motions.motion_text import (
    MotionFileError,
    cell_number,
    checked,
    csv_rows,
    normalised,
    open_motion,
)
from app.core.motions.roban_files import (
    SOLE_CONTACT_BAND_M,
    read_roban_motion_csv,
    sole_contacts,
)
from app.core.motions.trajectory import Trajectory, from_configurations
from app.core.robot.model import RobotModel

__all__ = [
    "BASE_Q_COLUMNS",
    "BASE_V_NAMES",
    "CONTACT_COLUMNS",
    "SOLE_CONTACT_BAND_M",
    "MotionFileError",
    "read_roban_motion_csv",
    "read_trajectory_csv",
    "sole_contacts",
    "write_trajectory_csv",
]

BASE_Q_COLUMNS = ("base_x", "base_y", "base_z", "base_qx", "base_qy", "base_qz", "base_qw")
BASE_V_NAMES = ("base_vx", "base_vy", "base_vz", "base_wx", "base_wy", "base_wz")
CONTACT_COLUMNS = ("contact_left", "contact_right")


@dataclasses.dataclass(frozen=True)
class _MovingJoint:
    name: str
    kind: str
    idx_q: int
    idx_v: int

    @property
    def linear(self) -> bool:
        return self.kind == "prismatic"


def _moving_joints(robot: RobotModel) -> list[_MovingJoint]:
    """Actuated joints in the robot's order, then the passive loop joints."""
    joints = [_MovingJoint(j.name, j.kind, j.idx_q, j.idx_v) for j in robot.joints]
    for name in robot.passive_joints:
        pin_joint = robot.model.joints[robot.model.getJointId(name)]
        kind = robot.tree.joints[name].kind
        joints.append(_MovingJoint(name, kind, pin_joint.idx_q, pin_joint.idx_v))
    return joints


def _columns(robot: RobotModel) -> list[tuple[str, str]]:
    """(name, unit) of every column, in the order they are written; unit "" when none."""
    joints = _moving_joints(robot)
    cols = [("t", "s")]
    if robot.floating_base:
        cols += [(name, "m") for name in BASE_Q_COLUMNS[:3]]
        cols += [(name, "") for name in BASE_Q_COLUMNS[3:]]
    cols += [(f"q:{j.name}", "m" if j.linear else "rad") for j in joints]
    for prefix, per in (("v", "/s"), ("a", "/s^2")):
        if robot.floating_base:
            cols += [(f"{prefix}:{name}", "m" + per) for name in BASE_V_NAMES[:3]]
            cols += [(f"{prefix}:{name}", "rad" + per) for name in BASE_V_NAMES[3:]]
        cols += [(f"{prefix}:{j.name}", ("m" if j.linear else "rad") + per) for j in joints]
    cols += [(name, "0/1") for name in CONTACT_COLUMNS]
    return cols


def _header_cell(name: str, unit: str) -> str:
    return f"{name} [{unit}]" if unit else name


def write_trajectory_csv(traj: Trajectory, path_or_file: TextPathOrFile, robot: RobotModel) -> None:
    """Write a trajectory of `robot` as a CSV file with a header row (see the module docstring)."""
    if traj.q.shape[1] != robot.model.nq or tuple(traj.joint_names) != robot.joint_names:
        raise MotionFileError(
            f"trajectory {traj.name!r} was made for another robot than {robot.name!r} "
            f"({traj.q.shape[1]} configuration values, the robot has {robot.model.nq})"
        )
    joints = _moving_joints(robot)
    n_base_v = 6 if robot.floating_base else 0

    def write(file: IO[str]) -> None:
        writer = csv.writer(file, lineterminator="\n")
        writer.writerow([_header_cell(name, unit) for name, unit in _columns(robot)])
        for k in range(traj.n_samples):
            q, v, a = traj.q[k], traj.v[k], traj.a[k]
            row = [float(traj.t[k])]
            if robot.floating_base:
                row += [float(x) for x in q[:7]]
            for j in joints:
                if j.kind == "continuous":
                    row.append(math.atan2(q[j.idx_q + 1], q[j.idx_q]))
                else:
                    row.append(float(q[j.idx_q]))
            for array in (v, a):
                row += [float(x) for x in array[:n_base_v]]
                row += [float(array[j.idx_v]) for j in joints]
            cells = [repr(x) for x in row]
            cells += ["1" if contact else "0" for contact in traj.contacts[k]]
            writer.writerow(cells)

    if isinstance(path_or_file, str | os.PathLike):
        write_atomically(path_or_file, write, MotionFileError)
    else:
        write(path_or_file)


_HEADER_CELL = re.compile(r"^\s*(?P<name>.*?)\s*(?:\[(?P<unit>[^\]]*)\])?\s*$")


def _is_number(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return False
    return True


def read_trajectory_csv(path_or_file: TextPathOrFile, robot: RobotModel) -> Trajectory:
    """Read a CSV file written by write_trajectory_csv (or by hand in the same format)."""
    file, owned, source = open_motion(path_or_file)
    try:
        return _read_table(csv_rows(file, source), source, robot)
    finally:
        if owned:
            file.close()


def _read_table(
    table: Iterator[tuple[int, list[str]]], source: str, robot: RobotModel
) -> Trajectory:
    """The trajectory in the rows of a motion CSV, parsed row by row (each row becomes numbers
    as it is read: a 64 MiB file never sits in memory as millions of strings)."""
    first = next(table, None)
    if first is None:
        raise MotionFileError(f"{source}: the file is empty")
    header_line, header = first
    if all(_is_number(cell) for cell in header):
        raise MotionFileError(
            f"{source}: line {header_line} holds numbers, not a header row naming the columns "
            "(t [s], base_x [m], …, q:<joint> [rad], …); a headerless Roban motion file is "
            "imported with read_roban_motion_csv"
        )

    index, has_derivatives = _header_index(header, source, robot)
    values, lines = _values(table, header, source)
    t = values[:, index["t"]]
    _check_times(t, lines, source)
    contacts = _contacts(values, index, lines, source)

    joints = _moving_joints(robot)
    q = np.tile(robot.q_neutral, (len(values), 1))
    if robot.floating_base:
        q[:, :3] = values[:, [index[name] for name in BASE_Q_COLUMNS[:3]]]
        quats = values[:, [index[name] for name in BASE_Q_COLUMNS[3:]]]
        q[:, 3:7] = normalised(quats, lines, source)
    for j in joints:
        angle = values[:, index[f"q:{j.name}"]]
        if j.kind == "continuous":
            q[:, j.idx_q], q[:, j.idx_q + 1] = np.cos(angle), np.sin(angle)
        else:
            q[:, j.idx_q] = angle
    name = Path(source).stem or "motion"
    dt = float(t[1] - t[0])
    if not has_derivatives:
        return checked(
            robot,
            from_configurations(robot.model, name, robot.joint_names, dt, q, contacts),
            source,
        )

    n_base_v = 6 if robot.floating_base else 0
    v = np.empty((len(values), robot.model.nv))
    a = np.empty_like(v)
    for prefix, array in (("v", v), ("a", a)):
        for i, base in enumerate(BASE_V_NAMES[:n_base_v]):
            array[:, i] = values[:, index[f"{prefix}:{base}"]]
        for j in joints:
            array[:, j.idx_v] = values[:, index[f"{prefix}:{j.name}"]]
    return checked(
        robot,
        Trajectory(
            name=name, joint_names=robot.joint_names, t=t - t[0], q=q, v=v, a=a, contacts=contacts
        ),
        source,
    )


def _header_index(header: list[str], source: str, robot: RobotModel) -> tuple[dict[str, int], bool]:
    """The column of each name in the header row, and whether it has the v: and a: columns
    (MotionFileError: an unknown, repeated or missing column, a wrong unit)."""
    expected = dict(_columns(robot))
    index: dict[str, int] = {}
    unknown: list[str] = []
    for column, cell in enumerate(header):
        match = _HEADER_CELL.match(cell)
        assert match is not None  # the pattern matches any text
        name, unit = match["name"], match["unit"]
        if name not in expected:
            unknown.append(name)
            continue
        if name in index:
            raise MotionFileError(f"{source}: column {name!r} appears twice in the header")
        if unit is not None and unit.strip() != expected[name]:
            raise MotionFileError(
                f"{source}: column {name!r} is in [{unit.strip()}], expected [{expected[name]}]"
            )
        index[name] = column
    if unknown:
        names = ", ".join(j.name for j in _moving_joints(robot))
        raise MotionFileError(
            f"{source}: unknown column(s) {', '.join(map(repr, unknown))} for robot "
            f"{robot.name!r}; its joints are: {names} (columns are t, base_*, q:<joint>, "
            "v:<joint>, a:<joint>, contact_left, contact_right)"
        )
    derivatives = [name for name in expected if name[:2] in ("v:", "a:")]
    required = [name for name in expected if name not in derivatives]
    has_derivatives = any(name in index for name in derivatives)
    missing = [
        name for name in required + (derivatives if has_derivatives else []) if name not in index
    ]
    if missing:
        shown = ", ".join(missing[:12]) + (" …" if len(missing) > 12 else "")
        raise MotionFileError(
            f"{source}: {len(missing)} column(s) missing for robot {robot.name!r}: {shown}"
            + (" (give all v: and a: columns or none)" if has_derivatives else "")
        )
    return index, has_derivatives


def _values(
    table: Iterator[tuple[int, list[str]]], header: list[str], source: str
) -> tuple[np.ndarray, list[int]]:
    """The sample rows as numbers, shape (rows, columns), and each row's line number."""
    labels = [cell.strip() for cell in header]
    rows: list[np.ndarray] = []
    lines: list[int] = []
    for line, cells in table:
        if len(cells) != len(header):
            raise MotionFileError(
                f"{source}, line {line}: {len(cells)} values, the header has {len(header)} columns"
            )
        rows.append(
            np.array(
                [
                    cell_number(cell, line, column + 1, labels[column], source)
                    for column, cell in enumerate(cells)
                ]
            )
        )
        lines.append(line)
    values = np.array(rows).reshape(len(rows), len(header))
    if len(values) < 2:
        raise MotionFileError(f"{source}: {len(values)} sample row(s); a motion needs at least 2")
    return values, lines


def _contacts(
    values: np.ndarray, index: dict[str, int], lines: list[int], source: str
) -> np.ndarray:
    """The contact columns as flags, shape (rows, 2) (MotionFileError: not 0 or 1)."""
    contacts = np.empty((len(values), 2), dtype=bool)
    for side, name in enumerate(CONTACT_COLUMNS):
        flags = values[:, index[name]]
        bad = np.flatnonzero((flags != 0.0) & (flags != 1.0))
        if len(bad):
            raise MotionFileError(
                f"{source}, line {lines[bad[0]]}, column {index[name] + 1} ({name}): "
                f"{flags[bad[0]]:g}; a contact is 0 or 1"
            )
        contacts[:, side] = flags == 1.0
    return contacts


def _check_times(t: np.ndarray, lines: list[int], source: str) -> None:
    steps = np.diff(t)
    if not steps[0] > 0.0:
        raise MotionFileError(
            f"{source}, line {lines[1]}: time {t[1]:g} s does not increase from {t[0]:g} s"
        )
    off = np.flatnonzero(np.abs(steps - steps[0]) > 1e-6 * steps[0])
    if len(off):
        k = off[0] + 1
        raise MotionFileError(
            f"{source}, line {lines[k]}: time step {steps[k - 1]:g} s differs from the first "
            f"step {steps[0]:g} s; samples must be evenly spaced in time"
        )
