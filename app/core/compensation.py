"""Servo spring and clearance compensation (Wang et al. 2023, `papers/spring-compensation-wbc.txt`).

A position-controlled servo under load behaves like a torsion spring: it settles short of its
command by an angle proportional to the torque it delivers. The paper pre-loads the command by
that deflection, using the torque feed-forward τ of the planned motion:

    q_des = q + k·τ                                                       (eq 7)
    q_des = q + k·τ + φ·sign(q + k·τ)                                     (eq 23)

q is the planned joint angle, q_des the command sent to the servo, k the spring compensation
coefficient and φ the clearance (backlash) compensation angle. The paper gives k in degrees per
N·m (Tables 2 and 3) and φ in degrees (8°, found by trial); this module takes them in those
units and converts inside, so joint angles are always radians.

The paper numbers its 12 leg servos 1–6 on the left leg and 7–12 on the right leg, each leg from
the pelvis down: hip yaw, hip roll, hip pitch, knee, ankle pitch, ankle roll (`LEG_ROLES`).
`servo_joint_names` finds those joints on any robot with two 6-joint legs (see there), and the
presets `paper_table3_preset` / `paper_table2_preset` put the paper's coefficients on them.
The coefficients are copied with the signs printed for Roban: they carry Roban's joint and
torque sign conventions (same axes on both legs, like `servo_biped`).

Pure numpy: no pinocchio, no GUI.
"""

from __future__ import annotations

import csv
import dataclasses
import math
import os
from collections.abc import Sequence
from itertools import permutations
from typing import IO, TYPE_CHECKING, Literal, TypeAlias

import numpy as np

from app.core.errors import StudioError

if TYPE_CHECKING:
    from app.core.model import RobotModel

ClearanceSign: TypeAlias = Literal["command", "torque"]
CLEARANCE_SIGNS: tuple[str, ...] = ("command", "torque")
MAX_ABS_K_DEG_PER_NM = 5000.0
"""Largest |k| accepted [°/(N·m)]. The paper's largest is 1200 (Table 3, servo 9)."""
MAX_PHI_DEG = 45.0
"""Largest clearance angle φ accepted [°]. The paper's is 8°."""
PAPER_PHI_DEG = 8.0
"""Clearance compensation angle of eq 23, found by trial (paper, section 5.4) [°]."""
PAPER_TABLE3_K_DEG_PER_NM: dict[int, float] = {2: -4.0, 3: -650.0, 8: 20.0, 9: -1200.0}
"""Table 3: k of servos 2, 3, 8, 9 after trial-and-error calibration [°/(N·m)]."""
LEG_ROLES = ("hip_yaw", "hip_roll", "hip_pitch", "knee", "ankle_pitch", "ankle_roll")
"""The paper's servo order within a leg; servo i (1–12) is LEG_ROLES[(i - 1) % 6] of the left
(1–6) or right (7–12) leg."""
MIN_AXIS_ALIGNMENT = 0.5
"""A joint takes a role (roll about x, pitch about y, yaw about z) only when |axis · that
direction| reaches this at q = 0 (Roban S14's 45°-tilted hip joint has 0.71)."""

PathOrFile: TypeAlias = str | os.PathLike[str] | IO[bytes]


class CompensationError(StudioError):
    """Compensation coefficients that are invalid or do not fit the robot."""


@dataclasses.dataclass(frozen=True, eq=False)
class CompensationParams:
    """Per-joint coefficients of eq 7 / eq 23, one entry per joint of `joint_names`."""

    joint_names: tuple[str, ...]
    k_deg_per_Nm: np.ndarray
    """Spring compensation coefficient k [°/(N·m)], shape (n,)."""
    phi_deg: np.ndarray
    """Clearance compensation angle φ [°], shape (n,), ≥ 0; 0 gives plain eq 7."""
    enabled: np.ndarray
    """Which joints are compensated, shape (n,) bool; a disabled joint is commanded q as planned."""
    clearance_sign: ClearanceSign = "command"
    """Direction in which φ is added (eq 23):

    - "command": the paper's rule, φ·sign(q + k·τ): the sign of the spring-compensated angle
      itself ("the direction of the angle is consistent with the direction of the angle after
      spring compensation", section 5.4). It depends on where the joint's zero is.
    - "torque": φ·sign(τ): towards the side the servo pushes. The load holds the gear train
      against the face of the dead band opposite to τ, so this is the exact inverse of the
      backlash model in `app.core.servo_model` with φ = b/2 (half the dead band).

    Both add nothing where their argument is exactly zero."""
    notes: tuple[str, ...] = ()
    """Where the numbers come from and anything corrected on the way (shown to the user)."""

    def __post_init__(self) -> None:
        names = tuple(self.joint_names)
        n = len(names)
        if len(set(names)) != n:
            dup = sorted({name for name in names if names.count(name) > 1})
            raise CompensationError(f"joint names given more than once: {', '.join(dup)}")
        arrays = {}
        for label, value in (("k_deg_per_Nm", self.k_deg_per_Nm), ("phi_deg", self.phi_deg)):
            try:
                array = np.array(value, dtype=float).reshape(-1)
            except (TypeError, ValueError) as error:
                raise CompensationError(f"{label} must be numbers: {error}") from None
            if array.shape != (n,):
                raise CompensationError(
                    f"{label} has {array.size} value(s) for {n} joint(s); give one per joint"
                )
            arrays[label] = array
        enabled = np.array(self.enabled, dtype=bool).reshape(-1)
        if enabled.shape != (n,):
            raise CompensationError(
                f"enabled has {enabled.size} value(s) for {n} joint(s); give one per joint"
            )
        k, phi = arrays["k_deg_per_Nm"], arrays["phi_deg"]
        for i, name in enumerate(names):
            if not math.isfinite(k[i]) or abs(k[i]) > MAX_ABS_K_DEG_PER_NM:
                raise CompensationError(
                    f"k of {name} is {float(k[i]):g} °/(N·m); it must be a number within "
                    f"±{MAX_ABS_K_DEG_PER_NM:g} (the paper's largest is 1200)"
                )
            if not math.isfinite(phi[i]) or not 0.0 <= phi[i] <= MAX_PHI_DEG:
                raise CompensationError(
                    f"φ of {name} is {float(phi[i]):g}°; it must be between 0 and {MAX_PHI_DEG:g}° "
                    "(the paper's is 8°; its direction comes from the sign rule)"
                )
        if self.clearance_sign not in CLEARANCE_SIGNS:
            raise CompensationError(
                f"clearance_sign is {self.clearance_sign!r}; it must be 'command' (the paper's "
                "sign(q + k·τ)) or 'torque' (sign(τ))"
            )
        for array in (k, phi, enabled):
            array.flags.writeable = False
        object.__setattr__(self, "joint_names", names)
        object.__setattr__(self, "k_deg_per_Nm", k)
        object.__setattr__(self, "phi_deg", phi)
        object.__setattr__(self, "enabled", enabled)
        object.__setattr__(self, "notes", tuple(self.notes))

    @property
    def n_joints(self) -> int:
        return len(self.joint_names)

    def for_joints(self, joint_names: Sequence[str]) -> CompensationParams:
        """The same coefficients laid out on `joint_names` (a robot's joints, in its order).

        Joints not named here are disabled (k = φ = 0). A joint named here that the robot lacks
        is an error, so a typo never silently drops a coefficient.
        """
        joint_names = tuple(joint_names)
        unknown = [name for name in self.joint_names if name not in joint_names]
        if unknown:
            shown = ", ".join(joint_names[:16]) + (" …" if len(joint_names) > 16 else "")
            raise CompensationError(
                f"no joint named {', '.join(repr(u) for u in unknown)} on this robot; "
                f"its joints are: {shown}"
            )
        if joint_names == self.joint_names:
            return self
        index = {name: i for i, name in enumerate(self.joint_names)}
        k, phi, on = np.zeros(len(joint_names)), np.zeros(len(joint_names)), []
        for j, name in enumerate(joint_names):
            i = index.get(name)
            if i is not None:
                k[j], phi[j] = self.k_deg_per_Nm[i], self.phi_deg[i]
            on.append(i is not None and bool(self.enabled[i]))
        return CompensationParams(
            joint_names, k, phi, np.array(on), self.clearance_sign, self.notes
        )

    def to_toml(self) -> str:
        """The coefficients as a k.toml file (see `read_coefficients_toml`)."""
        lines = [f'clearance_sign = "{self.clearance_sign}"', ""]
        for note in self.notes:
            lines.insert(0, f"# {note}")
        for i, name in enumerate(self.joint_names):
            lines += [
                f'[joints."{name}"]',
                f"k_deg_per_Nm = {float(self.k_deg_per_Nm[i])!r}",
                f"phi_deg = {float(self.phi_deg[i])!r}",
                f"enabled = {'true' if self.enabled[i] else 'false'}",
                "",
            ]
        return "\n".join(lines)


def disabled_params(joint_names: Sequence[str]) -> CompensationParams:
    """No compensation on any joint: the command is the plan."""
    n = len(joint_names)
    return CompensationParams(tuple(joint_names), np.zeros(n), np.zeros(n), np.zeros(n, bool))


def k_rad_per_Nm(k_deg_per_Nm: np.ndarray | float) -> np.ndarray:
    """A compliance in °/(N·m) as rad/(N·m)."""
    return np.deg2rad(np.asarray(k_deg_per_Nm, dtype=float))


def compensated_command(
    q_rad: np.ndarray, tau_Nm: np.ndarray, params: CompensationParams
) -> np.ndarray:
    """Servo commands q_des [rad], shape (T, n), for planned angles q [rad] and torques τ [N·m].

    Enabled joints: q_des = q + k·τ (eq 7), plus φ·sign(·) when φ > 0 (eq 23), the sign taken
    from `params.clearance_sign`. k·τ is in degrees (k in °/(N·m)) and φ in degrees; both are
    converted to radians here. Disabled joints: q_des = q. Columns follow `params.joint_names`.
    """
    q = np.asarray(q_rad, dtype=float)
    tau = np.asarray(tau_Nm, dtype=float)
    n = params.n_joints
    if q.ndim != 2 or q.shape[1] != n:
        raise CompensationError(f"planned angles have shape {q.shape}; expected (T, {n})")
    if tau.shape != q.shape:
        raise CompensationError(
            f"torques have shape {tau.shape} but planned angles {q.shape}; one torque per joint "
            "and sample is needed"
        )
    for label, array in (("planned angles", q), ("torques", tau)):
        if not np.all(np.isfinite(array)):
            bad = np.argwhere(~np.isfinite(array))[0]
            raise CompensationError(
                f"{label} contain NaN or infinite values (first at sample {bad[0]}, "
                f"joint {params.joint_names[bad[1]]})"
            )
    spring = q + k_rad_per_Nm(params.k_deg_per_Nm) * tau  # eq 7
    direction = np.sign(spring) if params.clearance_sign == "command" else np.sign(tau)
    command = spring + np.deg2rad(params.phi_deg) * direction  # eq 23
    return np.where(params.enabled, command, q)


def read_coefficients_toml(path_or_file: PathOrFile) -> CompensationParams:
    """Coefficients from a k.toml file::

        clearance_sign = "command"        # optional: "command" (paper, default) or "torque"
        [joints.left_hip_roll]
        k_deg_per_Nm = -4.0               # required [°/(N·m)]
        phi_deg = 8.0                     # optional [°], default 0
        enabled = true                    # optional, default true

    Only the joints listed are compensated; `CompensationParams.for_joints` checks the names.
    """
    try:
        import tomllib  # Python ≥ 3.11
    except ImportError:  # pragma: no cover - the studio runs on 3.11
        raise CompensationError("reading k.toml files needs Python 3.11 or newer") from None
    if isinstance(path_or_file, (str, os.PathLike)):
        source = os.fspath(path_or_file)
        try:
            with open(path_or_file, "rb") as file:
                data = tomllib.load(file)
        except OSError as error:
            raise CompensationError(f"cannot read {source}: {error.strerror}") from None
        except tomllib.TOMLDecodeError as error:
            raise CompensationError(f"{source}: not valid TOML: {error}") from None
    else:
        source = getattr(path_or_file, "name", "coefficients")
        try:
            data = tomllib.load(path_or_file)
        except tomllib.TOMLDecodeError as error:
            raise CompensationError(f"{source}: not valid TOML: {error}") from None
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


# --- the paper's servo numbering on a robot --------------------------------------------------


def servo_joint_names(robot: RobotModel) -> tuple[str, ...]:
    """The robot's joints for the paper's servos 1–12, in servo order (index = servo − 1).

    Legs are found from the feet, not from names: the actuated joints on the path from each
    foot up to the root, minus those both paths share (a waist), in order from the pelvis down.
    Each leg must have exactly 6. Their roles are then read from the joint axes at q = 0 in
    the root frame: the knee is the middle joint (4th from the pelvis), the two below it are
    the ankle (pitch about y, roll about x) and the three above it the hip (yaw about z, roll
    about x, pitch about y), assigned to the joints whose axes fit best. This works for
    servo_biped (yaw, roll, pitch, …), for robots whose hips are ordered differently, and for
    Roban S14, whose first hip joint turns about a 45°-tilted axis (it becomes hip pitch).
    """
    legs = _leg_chains(robot)
    names: list[str] = []
    for side, chain in zip(("left", "right"), legs, strict=True):
        axes = {name: axis for name, axis in chain}
        joints = [name for name, _ in chain]
        if len(joints) != 6:
            listed = ", ".join(joints) if joints else "none"
            raise CompensationError(
                f"the paper's servo numbering needs 6 actuated joints per leg (hip yaw, hip "
                f"roll, hip pitch, knee, ankle pitch, ankle roll); {robot.name}'s {side} leg "
                f"has {len(joints)}: {listed}"
            )
        hip = _assign(joints[:3], axes, ("hip_yaw", "hip_roll", "hip_pitch"), side)
        ankle = _assign(joints[4:], axes, ("ankle_pitch", "ankle_roll"), side)
        if abs(axes[joints[3]][1]) < MIN_AXIS_ALIGNMENT:
            raise CompensationError(
                f"{side} knee {joints[3]!r} does not turn about the lateral (y) axis at q = 0; "
                "cannot match the paper's servo numbering"
            )
        roles = {**hip, "knee": joints[3], **ankle}
        names += [roles[role] for role in LEG_ROLES]
    return tuple(names)


_ROLE_AXIS = {"yaw": 2, "roll": 0, "pitch": 1}


def _assign(
    joints: list[str], axes: dict[str, np.ndarray], roles: tuple[str, ...], side: str
) -> dict[str, str]:
    """Roles for joints: the permutation whose axes best match x (roll), y (pitch), z (yaw)."""

    def fit(order: tuple[str, ...]) -> list[float]:
        return [
            abs(float(axes[joint][_ROLE_AXIS[role.split("_")[1]]]))
            for joint, role in zip(order, roles, strict=True)
        ]

    best = max(permutations(joints), key=lambda order: sum(fit(order)))
    for joint, role, score in zip(best, roles, fit(best), strict=True):
        if score < MIN_AXIS_ALIGNMENT:
            raise CompensationError(
                f"no joint of the {side} {role.split('_')[0]} turns about the "
                f"{'xyz'[_ROLE_AXIS[role.split('_')[1]]]} axis at q = 0 ({joint!r} fits best, "
                f"|cos| = {score:.2f}); cannot match the paper's servo numbering"
            )
    return dict(zip(roles, best, strict=True))


def _leg_chains(robot: RobotModel) -> list[list[tuple[str, np.ndarray]]]:
    """Per foot (left, right): (joint, axis in the root frame at q = 0) of its leg's actuated
    joints, from the pelvis down, without the joints both feet hang from."""
    tree = robot.tree
    actuated = set(robot.joint_names)
    paths = []
    for foot in robot.feet:
        path, link = [], foot.link
        while (joint := tree.parent_joint(link)) is not None:
            path.append(joint)
            link = joint.parent
        paths.append(path[::-1])
    shared = {joint.name for joint in paths[0]} & {joint.name for joint in paths[1]}
    chains = []
    for path in paths:
        rotation, chain = np.eye(3), []
        for joint in path:
            rotation = rotation @ joint.T_parent_joint[:3, :3]
            if joint.name in actuated and joint.name not in shared:
                axis = rotation @ (joint.axis / np.linalg.norm(joint.axis))
                chain.append((joint.name, axis))
        chains.append(chain)
    return chains


def paper_table3_preset(robot: RobotModel, *, clearance: bool = False) -> CompensationParams:
    """Table 3 on the robot: k2 = −4, k3 = −650, k8 = 20, k9 = −1200 °/(N·m) on left hip roll,
    left hip pitch, right hip roll, right hip pitch; every other joint disabled. With
    `clearance`, φ = 8° on those four (eq 23, section 5.4), else φ = 0 (eq 7)."""
    servos = servo_joint_names(robot)
    phi = PAPER_PHI_DEG if clearance else 0.0
    by_joint = {servos[n - 1]: k for n, k in PAPER_TABLE3_K_DEG_PER_NM.items()}
    names = robot.joint_names
    note = "paper Table 3 (servos 2, 3, 8, 9: " + ", ".join(
        f"{n}→{servos[n - 1]}" for n in PAPER_TABLE3_K_DEG_PER_NM
    )
    note += f"), φ = {phi:g}° " + ("(eq 23)" if clearance else "(eq 7, no clearance)")
    return CompensationParams(
        names,
        np.array([by_joint.get(name, 0.0) for name in names]),
        np.array([phi if name in by_joint else 0.0 for name in names]),
        np.array([name in by_joint for name in names]),
        "command",
        (note,),
    )


def paper_table2_preset(robot: RobotModel) -> CompensationParams:
    """Table 2 on the robot: the standing k of all 12 leg servos, eq 7, no clearance.

    Each printed k is checked against its own row, (q_des − q)/τ, allowing for the rounding of
    the printed digits (`app.core.calibration.check_table2`); where they disagree (servo 11,
    printed −722.91, ten times its row's −72.29) the row's value is used and a note says so.
    """
    from app.core.calibration import check_table2

    servos = servo_joint_names(robot)
    k_by_joint, notes = {}, ["paper Table 2 (standing, servos 1–12)"]
    for check in check_table2():
        joint = servos[check.servo - 1]
        k_by_joint[joint] = check.k_printed if check.agrees else check.k_computed
        if not check.agrees:
            notes.append(
                f"servo {check.servo} ({joint}): printed k {check.k_printed:g} disagrees with "
                f"its row's (q_des − q)/τ = {check.k_computed:.2f}; using {check.k_computed:.2f}"
            )
    names = robot.joint_names
    return CompensationParams(
        names,
        np.array([k_by_joint.get(name, 0.0) for name in names]),
        np.zeros(len(names)),
        np.array([name in k_by_joint for name in names]),
        "command",
        tuple(notes),
    )


def command_limit_violations(
    params: CompensationParams, q_cmd_rad: np.ndarray, lower: np.ndarray, upper: np.ndarray
) -> list[str]:
    """One line per joint whose commands leave [lower, upper] [rad] (a preset's large k on a
    robot whose torques differ from Roban's can ask for more than the servo can turn)."""
    lines = []
    for i, name in enumerate(params.joint_names):
        column = q_cmd_rad[:, i]
        outside = (column < lower[i]) | (column > upper[i])
        if np.any(outside):
            lines.append(
                f"{name}: {int(outside.sum())} command(s) outside its limits "
                f"[{math.degrees(lower[i]):.1f}°, {math.degrees(upper[i]):.1f}°] "
                f"(range {math.degrees(column.min()):.1f}° … {math.degrees(column.max()):.1f}°)"
            )
    return lines


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


def read_torque_csv(
    path_or_file: str | os.PathLike[str] | IO[str], joint_names: Sequence[str]
) -> TorqueTable:
    """Read a torque feed-forward CSV: header `t [s]`, `tau:<joint> [N·m]` per joint (any
    order), optionally `status`; one row per sample. Every joint of `joint_names` must have a
    column, and every `tau:` column must name one of them."""
    if isinstance(path_or_file, (str, os.PathLike)):
        source = os.fspath(path_or_file)
        try:
            with open(source, newline="", encoding="utf-8-sig") as file:
                return _read_torque(file, str(source), joint_names)
        except OSError as error:
            raise CompensationError(f"cannot read {source}: {error.strerror}") from None
        except UnicodeDecodeError:
            raise CompensationError(f"{source}: not a UTF-8 text file") from None
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
    unknown = [name for name in tau_cols if name not in joint_names]
    if unknown:
        raise CompensationError(
            f"{source}: torque column(s) for joint(s) this robot does not have: "
            f"{', '.join(unknown)}; its joints are: {', '.join(joint_names)}"
        )
    missing = [name for name in joint_names if name not in tau_cols]
    if missing:
        raise CompensationError(
            f"{source}: no tau:<joint> column for {', '.join(missing)} (was the feed-forward "
            "computed for this robot?)"
        )
    columns = [time_col] + [tau_cols[name] for name in joint_names]
    rows, status = [], []
    for row in reader:
        line = reader.line_num
        if not any(cell.strip() for cell in row):
            continue
        if len(row) < len(header):
            raise CompensationError(
                f"{source}, line {line}: {len(row)} values for {len(header)} columns"
            )
        values = []
        for col in columns:
            cell = row[col].strip()
            try:
                value = float(cell)
            except ValueError:
                raise CompensationError(
                    f"{source}, line {line}: {header[col].strip()} {cell!r} is not a number"
                ) from None
            if not math.isfinite(value):
                raise CompensationError(
                    f"{source}, line {line}: {header[col].strip()} is {cell!r}; give a finite number"
                )
            values.append(value)
        rows.append(values)
        status.append(row[status_col].strip() if status_col is not None else "")
    if not rows:
        raise CompensationError(f"{source}: a header but no samples")
    table = np.array(rows)
    return TorqueTable(table[:, 0], table[:, 1:], tuple(status))
