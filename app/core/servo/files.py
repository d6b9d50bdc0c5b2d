"""Files of the compensation pipeline: coefficients (TOML), torque feed-forward (CSV) and
servo commands (CSV)."""

from __future__ import annotations

import csv
import dataclasses
import math
import os
from collections.abc import Sequence
from typing import IO, TYPE_CHECKING

import numpy as np

from app.core import input_gate
from app.core.atomic_write import write_atomically
from app.core.budgets import MAX_SAMPLES
from app.core.errors import finite_float, refuse_unknown_joints
from app.core.file_types import BinaryPathOrFile
from app.core.servo.compensation import CompensationError, CompensationParams

if TYPE_CHECKING:  # the QP's stack loads where torques are computed, not to read them
    from app.core.dynamics.wbc import FeedForward


def read_coefficients_toml(path_or_file: BinaryPathOrFile) -> CompensationParams:
    """Coefficients from a k.toml file::

        clearance_sign = "command"        # optional: "command" (paper, default) or "torque"
        [joints.left_hip_roll]
        k_deg_per_Nm = -4.0               # required [°/(N·m)]
        phi_deg = 8.0                     # optional [°], default 0
        enabled = true                    # optional, default true

    Only the joints listed are compensated; `CompensationParams.for_joints` checks the names.
    """
    if isinstance(path_or_file, (str, os.PathLike)):
        source = os.fspath(path_or_file)
        data = input_gate.read_toml(source, CompensationError)
    else:
        source = getattr(path_or_file, "name", "coefficients")
        raw = path_or_file.read(input_gate.TOML.max_bytes + 1)
        if len(raw) > input_gate.TOML.max_bytes:
            raise CompensationError(f"{source}: over the {input_gate.TOML.max_bytes} byte limit")
        text = input_gate.decode_text(raw, str(source), CompensationError)
        data = input_gate.parse_toml(text, str(source), CompensationError)
    return _params_from_mapping(data, str(source))


def _params_from_mapping(data: dict, source: str) -> CompensationParams:
    unknown = set(data) - {"clearance_sign", "joints"}
    if unknown:
        raise CompensationError(
            f"{source}: unknown key(s) {', '.join(sorted(unknown))}; expected clearance_sign "
            "and [joints.<name>] tables"
        )
    joints = data.get("joints")
    if not isinstance(joints, dict) or not joints:
        raise CompensationError(
            f"{source}: no [joints.<name>] tables; give k_deg_per_Nm for at least one joint"
        )
    names, k, phi, enabled = [], [], [], []
    for name, entry in joints.items():
        if not isinstance(entry, dict):
            raise CompensationError(f"{source}: joints.{name} must be a table")
        extra = set(entry) - {"k_deg_per_Nm", "phi_deg", "enabled"}
        if extra:
            raise CompensationError(
                f"{source}: joints.{name} has unknown key(s) {', '.join(sorted(extra))}; "
                "allowed: k_deg_per_Nm, phi_deg, enabled"
            )
        if "k_deg_per_Nm" not in entry:
            raise CompensationError(f"{source}: joints.{name} has no k_deg_per_Nm")
        values = []
        for key, default in (("k_deg_per_Nm", None), ("phi_deg", 0.0)):
            value = entry.get(key, default)
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise CompensationError(
                    f"{source}: joints.{name}.{key} must be a number, got {value!r}"
                )
            values.append(float(value))
        on = entry.get("enabled", True)
        if not isinstance(on, bool):
            raise CompensationError(
                f"{source}: joints.{name}.enabled must be true or false, got {on!r}"
            )
        names.append(name)
        k.append(values[0])
        phi.append(values[1])
        enabled.append(on)
    sign = data.get("clearance_sign", "command")
    return CompensationParams(
        tuple(names), np.array(k), np.array(phi), np.array(enabled), sign, (f"from {source}",)
    )


# --- torque feed-forward files --------------------------------------------------------------

TORQUE_UNITS = ("N·m", "N.m", "Nm", "N*m", "N m")


@dataclasses.dataclass(frozen=True, eq=False)
class TorqueTable:
    """A torque feed-forward read from CSV."""

    t: np.ndarray
    """Sample times [s], shape (T,)."""
    tau_Nm: np.ndarray
    """Joint torques [N·m], shape (T, n), columns in the order asked for."""
    status: tuple[str, ...]
    """The solver's status of each sample ("" when the file has no status column)."""


def write_torque_csv(path_or_file: str | os.PathLike[str] | IO[str], ff: FeedForward) -> None:
    """Write torques as CSV: `t [s]`, `tau:<joint> [N·m]` ([N] for a prismatic joint) per
    actuated joint, `status`; numbers as Python's repr (exact round trip)."""
    header = ["t [s]"]
    header += [f"tau:{n} [{u}]" for n, u in zip(ff.joint_names, ff.tau_units, strict=True)]
    if not isinstance(path_or_file, str | os.PathLike):
        _write_rows(path_or_file, header, ff)
        return
    write_atomically(path_or_file, lambda file: _write_rows(file, header, ff), CompensationError)


def _write_rows(file: IO[str], header: list[str], ff: FeedForward) -> None:
    writer = csv.writer(file, lineterminator="\n")
    writer.writerow([*header, "status"])
    for k, t in enumerate(ff.t):
        writer.writerow([repr(float(t)), *(repr(float(x)) for x in ff.tau_Nm[k]), ff.status[k]])


def read_torque_csv(
    path_or_file: str | os.PathLike[str] | IO[str], joint_names: Sequence[str]
) -> TorqueTable:
    """Read a torque feed-forward CSV: header `t [s]`, `tau:<joint> [N·m]` per joint (any
    order), optionally `status`; one row per sample. Every joint of `joint_names` must have a
    column, and every `tau:` column must name one of them."""
    if isinstance(path_or_file, (str, os.PathLike)):
        source = os.fspath(path_or_file)
        with input_gate.open_text(source, input_gate.TORQUE_CSV, CompensationError) as file:
            try:
                return _read_torque(file, source, joint_names)
            except UnicodeDecodeError as exc:
                raise CompensationError(
                    f"{source}: not UTF-8 text (byte {exc.start} of a block); save it as UTF-8"
                ) from None
    return _read_torque(path_or_file, str(getattr(path_or_file, "name", "torques")), joint_names)


def _read_torque(file: IO[str], source: str, joint_names: Sequence[str]) -> TorqueTable:
    reader = csv.reader(file)
    header = next(reader, None)
    if not header:
        raise CompensationError(
            f"{source}: empty file; expected a header t [s], tau:<joint> [N·m], …"
        )
    time_col, status_col, tau_cols = None, None, {}
    for i, cell in enumerate(header):
        name, _, unit = cell.strip().partition("[")
        name, unit = name.strip(), unit.rstrip("]").strip()
        if name == "t":
            time_col = i
        elif name == "status":
            status_col = i
        elif name.startswith("tau:"):
            if unit not in TORQUE_UNITS:
                raise CompensationError(
                    f"{source}, line 1: column {cell.strip()!r} must be in N·m, e.g. '{name} [N·m]'"
                )
            tau_cols[name[4:]] = i
    if time_col is None:
        raise CompensationError(f"{source}, line 1: no 't [s]' column")
    refuse_unknown_joints(tau_cols, joint_names, CompensationError, where=f"{source}: tau:<joint>")
    missing = [name for name in joint_names if name not in tau_cols]
    if missing:
        raise CompensationError(
            f"{source}: no tau:<joint> column for {', '.join(missing)} (was the feed-forward "
            "computed for this robot?)"
        )
    columns = [time_col] + [tau_cols[name] for name in joint_names]
    rows: list[list[float]] = []
    status: list[str] = []
    for row in reader:
        line = reader.line_num
        if not any(cell.strip() for cell in row):
            continue
        if len(rows) >= MAX_SAMPLES:
            raise CompensationError(f"{source}: more than {MAX_SAMPLES} samples; refused")
        if len(row) < len(header):
            raise CompensationError(
                f"{source}, line {line}: {len(row)} values for {len(header)} columns"
            )
        values = []
        for col in columns:
            where = f"{source}, line {line}: {header[col].strip()}"
            values.append(finite_float(row[col].strip(), where, CompensationError))
        rows.append(values)
        status.append(row[status_col].strip() if status_col is not None else "")
    if not rows:
        raise CompensationError(f"{source}: a header but no samples")
    table = np.array(rows)
    return TorqueTable(table[:, 0], table[:, 1:], tuple(status))


def write_command_csv(
    path_or_file: str | os.PathLike[str] | IO[str],
    t: np.ndarray,
    joint_names: Sequence[str],
    q_cmd_rad: np.ndarray,
    lower: np.ndarray | None = None,
    upper: np.ndarray | None = None,
) -> None:
    """Servo commands for the real robot: `t [s]`, then `q_cmd:<joint> [rad]` and
    `q_cmd:<joint> [deg]` columns, one row per sample.

    Nothing is written unless every command is finite and, when the joint limits `lower`,
    `upper` [rad] are given, within them (see `check_commands`); a path is written atomically.
    """
    check_commands(t, joint_names, q_cmd_rad, lower, upper)
    header = ["t [s]"]
    header += [f"q_cmd:{name} [rad]" for name in joint_names]
    header += [f"q_cmd:{name} [deg]" for name in joint_names]

    def write(file: IO[str]) -> None:
        writer = csv.writer(file)
        writer.writerow(header)
        for k, row in enumerate(np.asarray(q_cmd_rad, dtype=float)):
            radians = [float(value) for value in row]
            writer.writerow(
                [repr(float(t[k]))]
                + [repr(value) for value in radians]
                + [repr(math.degrees(value)) for value in radians]
            )

    if isinstance(path_or_file, (str, os.PathLike)):
        write_atomically(path_or_file, write, CompensationError)
    else:
        write(path_or_file)


def check_commands(
    t: np.ndarray,
    joint_names: Sequence[str],
    q_cmd_rad: np.ndarray,
    lower: np.ndarray | None = None,
    upper: np.ndarray | None = None,
) -> None:
    """CompensationError naming the joint and sample of the first command that is not finite
    or (limits given) outside [lower, upper] [rad]: such a file must never reach a servo."""
    q = np.asarray(q_cmd_rad, dtype=float)
    bad = ~np.isfinite(q)
    if lower is not None and upper is not None:
        with np.errstate(invalid="ignore"):
            bad |= (q < np.asarray(lower)[None, :] - 1e-12) | (
                q > np.asarray(upper)[None, :] + 1e-12
            )
    if not bad.any():
        return
    k, j = (int(i) for i in np.argwhere(bad)[0])
    value = q[k, j]
    if not math.isfinite(value):
        why = f"is {value}"
    else:
        assert lower is not None and upper is not None
        why = (
            f"is {math.degrees(value):.6g}°, outside its limits "
            f"[{math.degrees(lower[j]):.4g}°, {math.degrees(upper[j]):.4g}°]"
        )
    raise CompensationError(
        f"servo command of {joint_names[j]} at sample {k} (t = {float(t[k]):g} s) {why}; "
        f"{int(bad.sum())} command(s) refused, nothing written (check the torques and k)"
    )
