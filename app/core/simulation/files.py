"""Files of the simulation: servo commands in (CSV), virtual servos in (TOML), runs out (CSV).

servo.toml (every key optional; per-joint tables override the defaults at the top)::

    compliance_deg_per_Nm = 1.4      # the servos' true compliance c [°/(N·m)]
    backlash_deg = 0.5               # full dead-band width b [°]
    legs_only = true                 # the defaults apply to leg joints only (else: all)
    [joints.left_knee]
    compliance_deg_per_Nm = 1.55
    backlash_deg = 0.5

Without a file (or where a file leaves the top keys out) the studio's default virtual servos
apply: the paper's servo sized to the robot (`app.core.servo.scaling`: 1.4 °/(N·m), Table 2's
identifiable servos, divided by the robot's m·g·h over the paper robot's) and a 0.5° dead band
on every leg joint, other joints rigid.
"""

from __future__ import annotations

import csv
import math
import os
from collections.abc import Sequence
from typing import IO

import numpy as np

from app.core.errors import finite_float, refuse_unknown_joints
from app.core.robot.model import RobotModel
from app.core.servo.model import ServoModel
from app.core.servo.presets import TYPICAL_COMPLIANCE_DEG_PER_NM, uniform_preset
from app.core.servo.scaling import scaled_ideal_servo
from app.core.simulation.errors import SimulationInputError
from app.core.simulation.result import SimulationResult

DEFAULT_BACKLASH_DEG = 0.5
"""Dead band of the studio's default virtual servos [°] (a typical hobby servo's gear play):
the Compensation panel's default and a sweep's when it does not vary it."""
_SERVO_KEYS = {"compliance_deg_per_Nm", "backlash_deg"}


def default_servos(
    robot: RobotModel,
    compliance_deg_per_Nm: float = TYPICAL_COMPLIANCE_DEG_PER_NM,
    backlash_deg: float = DEFAULT_BACKLASH_DEG,
    legs_only: bool = True,
) -> ServoModel:
    """The same servo on every leg joint (or every joint), the others rigid."""
    legs = uniform_preset(robot).enabled if legs_only else np.ones(robot.n_actuated, bool)
    return ServoModel(
        robot.joint_names,
        np.where(legs, compliance_deg_per_Nm, 0.0),
        np.where(legs, backlash_deg, 0.0),
    )


def sized_servos(robot: RobotModel) -> ServoModel:
    """The default virtual servos of a robot without servo data: the paper's servo sized to
    the robot by m·g·h (`app.core.servo.scaling`) on every leg joint, the others rigid."""
    scaled = scaled_ideal_servo(robot)
    return default_servos(robot, scaled.compliance_deg_per_Nm, scaled.dead_band_deg)


def read_servo_toml(path: str | os.PathLike[str], robot: RobotModel) -> ServoModel:
    """Virtual servos from a servo.toml (module docstring), laid out on the robot's joints."""
    import tomllib

    source = os.fspath(path)
    try:
        with open(source, "rb") as file:
            data = tomllib.load(file)
    except OSError as error:
        raise SimulationInputError(f"cannot read {source}: {error.strerror}") from None
    except tomllib.TOMLDecodeError as error:
        raise SimulationInputError(f"{source}: not valid TOML: {error}") from None
    unknown = set(data) - _SERVO_KEYS - {"legs_only", "joints"}
    if unknown:
        raise SimulationInputError(
            f"{source}: unknown key(s) {', '.join(sorted(unknown))}; expected "
            "compliance_deg_per_Nm, backlash_deg, legs_only and [joints.<name>] tables"
        )
    defaults = default_servos(
        robot,
        _number(
            data, "compliance_deg_per_Nm", source, scaled_ideal_servo(robot).compliance_deg_per_Nm
        ),
        _number(data, "backlash_deg", source, DEFAULT_BACKLASH_DEG),
        bool(data.get("legs_only", True)),
    )
    compliance = np.array(defaults.compliance_deg_per_Nm)
    backlash = np.array(defaults.backlash_deg)
    joints = data.get("joints", {})
    if not isinstance(joints, dict):
        raise SimulationInputError(f"{source}: [joints] must be tables [joints.<name>]")
    refuse_unknown_joints(
        joints, robot.joint_names, SimulationInputError, where=source, robot=robot.name
    )
    for name, table in joints.items():
        if not isinstance(table, dict) or set(table) - _SERVO_KEYS:
            raise SimulationInputError(
                f"{source}: [joints.{name}] takes compliance_deg_per_Nm and backlash_deg only"
            )
        i = robot.joint_names.index(name)
        compliance[i] = _number(table, "compliance_deg_per_Nm", source, compliance[i])
        backlash[i] = _number(table, "backlash_deg", source, backlash[i])
    return ServoModel(robot.joint_names, compliance, backlash)


def _number(table: dict, key: str, source: str, default: float) -> float:
    value = table.get(key, default)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise SimulationInputError(f"{source}: {key} is {value!r}; give a finite number")
    return float(value)


def read_command_csv(
    path: str | os.PathLike[str], joint_names: Sequence[str], n_samples: int
) -> np.ndarray:
    """Servo commands [rad], shape (T, n), from a command CSV (`biped-studio compensate --out`):
    `t [s]`, then `q_cmd:<joint> [rad]` columns (degree columns are ignored)."""
    source = os.fspath(path)
    try:
        with open(source, newline="", encoding="utf-8-sig") as file:
            rows = list(csv.reader(file))
    except OSError as error:
        raise SimulationInputError(f"cannot read {source}: {error.strerror}") from None
    except UnicodeDecodeError:
        raise SimulationInputError(f"{source}: not a UTF-8 text file") from None
    if not rows:
        raise SimulationInputError(f"{source} is empty; expected a command CSV")
    header = [cell.strip() for cell in rows[0]]
    columns = []
    for name in joint_names:
        label = f"q_cmd:{name} [rad]"
        if label not in header:
            raise SimulationInputError(f"{source} has no column {label!r}; is it for this robot?")
        columns.append(header.index(label))
    body = [row for row in rows[1:] if any(cell.strip() for cell in row)]
    if len(body) != n_samples:
        raise SimulationInputError(
            f"{source} has {len(body)} command rows but the motion has {n_samples} samples"
        )
    out = np.empty((n_samples, len(joint_names)))
    for k, row in enumerate(body):
        for j, col in enumerate(columns):
            if col >= len(row):
                raise SimulationInputError(f"{source}, row {k + 2}: too few cells")
            out[k, j] = finite_float(
                row[col], f"{source}, row {k + 2}, {joint_names[j]}:", SimulationInputError
            )
    return out


def write_simulation_csv(
    path_or_file: str | os.PathLike[str] | IO[str], result: SimulationResult
) -> None:
    """One row per sample: t, base pose, torso roll/pitch [°], joint angles [rad], servo
    torques [N·m], vertical sole forces [N], sole slip [m], fallen (0/1)."""
    names = result.joint_names
    header = ["t [s]", "base_x [m]", "base_y [m]", "base_z [m]"]
    header += [f"base_q{c} [1]" for c in "xyzw"]
    header += ["roll [deg]", "pitch [deg]", "roll_planned [deg]", "pitch_planned [deg]"]
    header += [f"q:{n} [rad]" for n in names] + [f"tau:{n} [N·m]" for n in names]
    header += ["force_left_z [N]", "force_right_z [N]", "slip_left [m]", "slip_right [m]"]
    header += ["fallen [1]"]

    def write(file: IO[str]) -> None:
        writer = csv.writer(file)
        writer.writerow(header)
        for k, t in enumerate(result.t):
            fallen = result.fell and t >= (result.fall_time_s or 0.0)
            values = [
                t,
                *result.q[k, :7],
                math.degrees(result.roll_rad[k]),
                math.degrees(result.pitch_rad[k]),
                math.degrees(result.roll_planned_rad[k]),
                math.degrees(result.pitch_planned_rad[k]),
                *result.q_joints_rad[k],
                *result.tau_Nm[k],
                *result.contact_force_N[k, :, 2],
                *result.slip_m[k],
                1.0 if fallen else 0.0,
            ]
            writer.writerow([repr(float(v)) for v in values])

    if isinstance(path_or_file, (str, os.PathLike)):
        try:
            with open(path_or_file, "w", newline="", encoding="utf-8") as file:
                write(file)
        except OSError as error:
            raise SimulationInputError(f"cannot write {path_or_file}: {error.strerror}") from None
    else:
        write(path_or_file)
