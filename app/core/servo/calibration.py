"""Calibrating the spring coefficient k of each servo from measurements (paper, sections 4.4, 5.2).

The robot is commanded frame by frame; once it has settled, each servo's encoder angle is read
and its torque taken from the feed-forward. Eq 7, q_des = q + k·τ, then gives one equation per
frame and joint, and k is fitted by least squares over the frames ("the spring compensation
coefficient of each steering gear of the robot can be obtained by the least squares fitting
method", section 4.4).

The fit goes through the origin, k = Σ τ·d / Σ τ² with d = q_cmd − q_meas, because that is
the paper's k: eq 7 has no constant term, Table 2's k is d/τ of a single frame, and a single
standing frame per servo (how the paper measured) cannot support an intercept. A servo whose
zero is off would bias k, so with three frames or more and varying torque the fit with an
intercept, d = k'·τ + offset, is reported beside it as a diagnostic (`offset_deg`).

Measured files are in long format, one row per frame and joint::

    frame,joint,q_cmd_deg,q_meas_deg,tau_Nm
    0,left_hip_roll,0.6226,0.15625,-0.36474
"""

from __future__ import annotations

import csv
import dataclasses
import io
import math
import os
from collections.abc import Iterable
from typing import IO

import numpy as np

from app.core import input_gate
from app.core.errors import StudioError, finite_float
from app.core.file_types import TextPathOrFile
from app.core.papers import TABLE2_TEXT

MEASURED_COLUMNS = ("frame", "joint", "q_cmd_deg", "q_meas_deg", "tau_Nm")
ENCODER_RESOLUTION_DEG = 360.0 / 4608.0
"""0.078125°: every measured angle q of the paper's Table 2 is a whole multiple of it."""
MIN_ABS_TAU_NM = 0.05
"""Below this largest |τ| a k is not identifiable: the torque model's own error is of that
order, and the deflection k·τ drowns in encoder steps."""
MAX_RELATIVE_SE = 0.25
"""A k whose standard error exceeds this fraction of |k| is not identifiable."""
MIN_DEFLECTION_STEPS = 2.0
"""The fitted deflection |k|·max|τ| must span at least this many encoder steps."""
MAX_MEASURED_BYTES = input_gate.MEASURED_CSV.max_bytes
MAX_MEASURED_ROWS = 200_000
"""Measurement rows read (one per frame and joint): a long calibration session of 12 servos."""


class CalibrationError(StudioError):
    """A measurement file that cannot be read."""


@dataclasses.dataclass(frozen=True, eq=False)
class Measurements:
    """Settled servo readings, one entry per (frame, joint); arrays of shape (N,)."""

    source: str
    frame: np.ndarray
    """Frame number (integer)."""
    joint: tuple[str, ...]
    q_cmd_deg: np.ndarray
    """Commanded angle q_des [°]."""
    q_meas_deg: np.ndarray
    """Measured (encoder) angle q [°]."""
    tau_Nm: np.ndarray
    """Torque the servo delivers [N·m] (from the feed-forward)."""

    @property
    def joint_names(self) -> tuple[str, ...]:
        """Joints in the order they first appear."""
        return tuple(dict.fromkeys(self.joint))


@dataclasses.dataclass(frozen=True)
class JointCalibration:
    """The fitted k of one joint, with how far to trust it."""

    joint: str
    n_frames: int
    k_deg_per_Nm: float
    """Least-squares k through the origin [°/(N·m)]; NaN when every τ is zero."""
    se_deg_per_Nm: float
    """Standard error of k [°/(N·m)]; NaN with a single frame (no residual to judge by)."""
    identifiable: bool
    reason: str
    """Why k is not identifiable, or what limits it; "" when there is nothing to say."""
    max_abs_tau_Nm: float
    rms_residual_deg: float
    """RMS of d − k·τ [°]; NaN without frames."""
    k_with_offset_deg_per_Nm: float = math.nan
    """k of the fit with an intercept (≥ 3 frames, varying τ), else NaN."""
    offset_deg: float = math.nan
    """Intercept of that fit [°], e.g. a servo zero offset; NaN when not fitted."""

    def to_json(self) -> dict[str, object]:
        def number(value: float) -> float | None:
            return None if math.isnan(value) else value

        return {
            "joint": self.joint,
            "n_frames": self.n_frames,
            "k_deg_per_Nm": number(self.k_deg_per_Nm),
            "se_deg_per_Nm": number(self.se_deg_per_Nm),
            "identifiable": self.identifiable,
            "reason": self.reason,
            "max_abs_tau_Nm": self.max_abs_tau_Nm,
            "rms_residual_deg": number(self.rms_residual_deg),
            "k_with_offset_deg_per_Nm": number(self.k_with_offset_deg_per_Nm),
            "offset_deg": number(self.offset_deg),
        }


def read_measured_csv(path_or_file: TextPathOrFile) -> Measurements:
    """Read a long-format measurement CSV (header `frame,joint,q_cmd_deg,q_meas_deg,tau_Nm`,
    columns in any order, extra columns ignored). Every problem names its line."""
    if isinstance(path_or_file, (str, os.PathLike)):
        source = os.fspath(path_or_file)
        text = input_gate.read_text(source, input_gate.MEASURED_CSV, CalibrationError)
        return _read(io.StringIO(text, newline=""), source)
    return _read(path_or_file, str(getattr(path_or_file, "name", "measurements")))


def _read(file: IO[str], source: str) -> Measurements:
    reader = csv.reader(file)
    header: list[str] | None = None
    header_line = 0
    for row in reader:
        if any(cell.strip() for cell in row):
            header = [cell.strip() for cell in row]
            header_line = reader.line_num
            break
    if header is None:
        raise CalibrationError(
            f"{source}: empty file; expected a header {','.join(MEASURED_COLUMNS)}"
        )
    missing = [name for name in MEASURED_COLUMNS if name not in header]
    if missing:
        raise CalibrationError(
            f"{source}, line {header_line}: missing column(s) {', '.join(missing)}; the header "
            f"must name {','.join(MEASURED_COLUMNS)} (got {','.join(header)})"
        )
    col = {name: header.index(name) for name in MEASURED_COLUMNS}
    frames: list[int] = []
    joints: list[str] = []
    values: list[tuple[float, float, float]] = []
    seen: dict[tuple[int, str], int] = {}
    for row in reader:
        line = reader.line_num
        if not any(cell.strip() for cell in row):
            continue
        if len(frames) >= MAX_MEASURED_ROWS:
            raise CalibrationError(
                f"{source}, line {line}: more than {MAX_MEASURED_ROWS} measurements; refused"
            )
        if len(row) < len(header):
            raise CalibrationError(
                f"{source}, line {line}: {len(row)} value(s) for {len(header)} columns"
            )
        frame_text = row[col["frame"]].strip()
        try:
            frame = int(frame_text)
        except ValueError:
            raise CalibrationError(
                f"{source}, line {line}: frame {frame_text!r} is not a whole number"
            ) from None
        joint = row[col["joint"]].strip()
        if not joint:
            raise CalibrationError(f"{source}, line {line}: empty joint name")
        numbers = []
        for name in MEASURED_COLUMNS[2:]:
            where = f"{source}, line {line}: {name}"
            numbers.append(finite_float(row[col[name]].strip(), where, CalibrationError))
        if (frame, joint) in seen:
            raise CalibrationError(
                f"{source}, line {line}: frame {frame} of {joint} already given on line "
                f"{seen[frame, joint]}"
            )
        seen[frame, joint] = line
        frames.append(frame)
        joints.append(joint)
        values.append((numbers[0], numbers[1], numbers[2]))
    if not frames:
        raise CalibrationError(f"{source}: a header but no measurements")
    array = np.array(values, dtype=float)
    return Measurements(
        source=source,
        frame=np.array(frames, dtype=int),
        joint=tuple(joints),
        q_cmd_deg=array[:, 0],
        q_meas_deg=array[:, 1],
        tau_Nm=array[:, 2],
    )


def calibrate(
    measured: Measurements,
    *,
    min_abs_tau_Nm: float = MIN_ABS_TAU_NM,
    max_relative_se: float = MAX_RELATIVE_SE,
    resolution_deg: float = ENCODER_RESOLUTION_DEG,
) -> list[JointCalibration]:
    """k per joint by least squares on q_cmd − q_meas = k·τ (eq 7, through the origin).

    k = Σ τ·d / Σ τ², standard error SE = sqrt(Σ r² / (n − 1) / Σ τ²) with r = d − k·τ.
    A joint is identifiable when its largest |τ| reaches `min_abs_tau_Nm`, the fitted
    deflection |k|·max|τ| spans `MIN_DEFLECTION_STEPS` encoder steps of `resolution_deg`, and
    (with two frames or more) SE ≤ `max_relative_se`·|k|. Joints come in order of appearance.
    """
    out = []
    joint_of = np.array(measured.joint, dtype=object)
    for name in measured.joint_names:
        rows = joint_of == name
        d = measured.q_cmd_deg[rows] - measured.q_meas_deg[rows]
        out.append(
            _fit(name, measured.tau_Nm[rows], d, min_abs_tau_Nm, max_relative_se, resolution_deg)
        )
    return out


def _fit(
    name: str,
    tau: np.ndarray,
    d: np.ndarray,
    min_abs_tau: float,
    max_relative_se: float,
    resolution_deg: float,
) -> JointCalibration:
    n = len(tau)
    max_tau = float(np.max(np.abs(tau)))
    sxx = float(tau @ tau)
    if sxx == 0.0:
        return JointCalibration(
            name, n, math.nan, math.nan, False,
            "every torque is zero: the deflection says nothing about k",
            max_tau, float(np.sqrt(np.mean(d**2))),
        )  # fmt: skip
    k = float(tau @ d) / sxx
    residual = d - k * tau
    rms = float(np.sqrt(np.mean(residual**2)))
    se = float(np.sqrt(residual @ residual / (n - 1) / sxx)) if n >= 2 else math.nan
    k_offset, offset = math.nan, math.nan
    if n >= 3 and np.ptp(tau) > 0.0:
        design = np.column_stack([tau, np.ones(n)])
        (k_offset, offset), *_ = np.linalg.lstsq(design, d, rcond=None)
    problems = []
    if max_tau < min_abs_tau:
        problems.append(
            f"largest |τ| is {max_tau:.3g} N·m, below {min_abs_tau:g} N·m: torque model error "
            "and encoder steps swamp the deflection"
        )
    deflection = abs(k) * max_tau
    if resolution_deg > 0.0 and deflection < MIN_DEFLECTION_STEPS * resolution_deg:
        problems.append(
            f"fitted deflection {deflection:.3g}° spans under {MIN_DEFLECTION_STEPS:g} encoder "
            f"steps of {resolution_deg:.3g}°"
        )
    if n >= 2 and se > max_relative_se * abs(k):
        problems.append(
            f"standard error {se:.3g} is {se / abs(k):.0%} of |k| (limit {max_relative_se:.0%})"
        )
    reason = "; ".join(problems)
    if not problems and n == 1:
        reason = "one frame: k = (q_cmd − q_meas)/τ exactly, no standard error"
    return JointCalibration(
        name, n, k, se, not problems, reason, max_tau, rms, float(k_offset), float(offset)
    )


# --- the paper's Table 2 -------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class Table2Row:
    servo: int
    q_des_deg: float
    q_deg: float
    tau_Nm: float
    k_printed: float
    half_units: tuple[float, float, float, float]
    """Half a unit of the last printed digit of q_des, q, τ, k: the rounding each may carry."""


@dataclasses.dataclass(frozen=True)
class Table2Check:
    servo: int
    k_printed: float
    k_computed: float
    """(q_des − q)/τ from the row's own columns."""
    k_low: float
    k_high: float
    """Range of (q_des − q)/τ over the rounding of the printed q_des, q and τ."""
    agrees: bool
    """Whether the printed k (± its own rounding) meets that range."""
    note: str


def table2_rows() -> tuple[Table2Row, ...]:
    """The paper's Table 2 as data, with the rounding of every printed number."""
    rows = []
    for line in TABLE2_TEXT.splitlines():
        cells = line.split()
        q_des, q, tau, k = (float(cell) for cell in cells[1:])
        h = [0.5 * 10.0 ** -_decimals(cell) for cell in cells[1:]]
        rows.append(Table2Row(int(cells[0]), q_des, q, tau, k, (h[0], h[1], h[2], h[3])))
    return tuple(rows)


def _decimals(cell: str) -> int:
    return len(cell.split(".")[1]) if "." in cell else 0


def check_table2(rows: Iterable[Table2Row] | None = None) -> list[Table2Check]:
    """Check every printed k against (q_des − q)/τ of its own row.

    A printed k agrees when it lies, within its own last-digit rounding, inside the range
    (q_des − q)/τ takes as q_des, q and τ move by half a unit of their last printed digit.
    Servo 11 fails: its printed −722.91 is ten times its row's −72.29.
    """
    out = []
    for row in table2_rows() if rows is None else rows:
        h_des, h_q, h_tau, h_k = row.half_units
        d = row.q_des_deg - row.q_deg
        k = d / row.tau_Nm
        corners = [
            (d + sd * (h_des + h_q)) / (row.tau_Nm + st * h_tau) for sd in (-1, 1) for st in (-1, 1)
        ]
        low, high = min(corners), max(corners)
        if abs(row.tau_Nm) <= h_tau:  # τ could be zero within its rounding
            low, high = -math.inf, math.inf
        agrees = low - h_k <= row.k_printed <= high + h_k
        note = ""
        if not agrees:
            note = (
                f"printed k {row.k_printed:g} is {row.k_printed / k:.2f} × the row's "
                f"(q_des − q)/τ = {k:.2f}"
            )
        out.append(Table2Check(row.servo, row.k_printed, k, low, high, agrees, note))
    return out
