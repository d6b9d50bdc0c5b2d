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

The paper's coefficients (Tables 2 and 3) and its servo numbering live in
app.core.servo.presets; coefficient and torque files in app.core.servo.files.

Pure numpy: no pinocchio, no GUI.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import ClassVar, Literal, TypeAlias

import numpy as np

from app.core.errors import StudioError
from app.core.papers import PHI_DEG
from app.core.servo.per_joint import PerJointRecord, check_range, per_joint

ClearanceSign: TypeAlias = Literal["command", "torque"]
CLEARANCE_SIGNS: tuple[str, ...] = ("command", "torque")
MAX_ABS_K_DEG_PER_NM = 5000.0
"""Largest |k| accepted [°/(N·m)]. The paper's largest is 1200 (Table 3, servo 9)."""
MAX_PHI_DEG = 45.0
"""Largest clearance angle φ accepted [°]. The paper's is 8°."""
PAPER_PHI_DEG = PHI_DEG
"""Clearance compensation angle of eq 23 (app.core.papers) [°]."""


class CompensationError(StudioError):
    """Compensation coefficients that are invalid or do not fit the robot."""


@dataclasses.dataclass(frozen=True, eq=False)
class CompensationParams(PerJointRecord):
    """Per-joint coefficients of eq 7 / eq 23, one entry per joint of `joint_names`
    (`for_joints`: joints not named are disabled, k = φ = 0)."""

    COLUMNS: ClassVar[tuple[str, ...]] = ("k_deg_per_Nm", "phi_deg", "enabled")
    ERROR: ClassVar[type[StudioError]] = CompensationError

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
      backlash model in `app.core.servo.model` with φ = b/2 (half the dead band).

    Both add nothing where their argument is exactly zero."""
    notes: tuple[str, ...] = ()
    """Where the numbers come from and anything corrected on the way (shown to the user)."""

    def __post_init__(self) -> None:
        names = tuple(self.joint_names)
        n = len(names)
        if len(set(names)) != n:
            dup = sorted({name for name in names if names.count(name) > 1})
            raise CompensationError(f"joint names given more than once: {', '.join(dup)}")
        k = per_joint("k_deg_per_Nm", self.k_deg_per_Nm, n, CompensationError)
        phi = per_joint("phi_deg", self.phi_deg, n, CompensationError)
        enabled = np.array(self.enabled, dtype=bool).reshape(-1)
        if enabled.shape != (n,):
            raise CompensationError(
                f"enabled has {enabled.size} value(s) for {n} joint(s); give one per joint"
            )
        enabled.flags.writeable = False
        check_range(
            "k",
            k,
            names,
            (-MAX_ABS_K_DEG_PER_NM, MAX_ABS_K_DEG_PER_NM),
            " °/(N·m)",
            CompensationError,
            " (the paper's largest is 1200)",
        )
        check_range(
            "φ",
            phi,
            names,
            (0.0, MAX_PHI_DEG),
            "°",
            CompensationError,
            " (the paper's is 8°; its direction comes from the sign rule)",
        )
        if self.clearance_sign not in CLEARANCE_SIGNS:
            raise CompensationError(
                f"clearance_sign is {self.clearance_sign!r}; it must be 'command' (the paper's "
                "sign(q + k·τ)) or 'torque' (sign(τ))"
            )
        object.__setattr__(self, "joint_names", names)
        object.__setattr__(self, "k_deg_per_Nm", k)
        object.__setattr__(self, "phi_deg", phi)
        object.__setattr__(self, "enabled", enabled)
        object.__setattr__(self, "notes", tuple(self.notes))

    @property
    def n_joints(self) -> int:
        return len(self.joint_names)

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
    return checked_command(q, tau, params)


def checked_command(
    q_rad: np.ndarray, tau_Nm: np.ndarray, params: CompensationParams
) -> np.ndarray:
    """`compensated_command`'s equations alone, for inputs it has already accepted (float
    arrays (T, n), finite): a slider's re-prediction checks its fixed plan and torques once."""
    with np.errstate(over="ignore", invalid="ignore"):  # huge τ: inf, refused when written
        spring = q_rad + k_rad_per_Nm(params.k_deg_per_Nm) * tau_Nm  # eq 7
        direction = np.sign(spring) if params.clearance_sign == "command" else np.sign(tau_Nm)
        spring += np.deg2rad(params.phi_deg) * direction  # eq 23
    return np.where(params.enabled, spring, q_rad)


def drive_torque_Nm(
    tau_Nm: np.ndarray,
    qd_rad_s: np.ndarray,
    qdd_rad_s2: np.ndarray,
    damping_Nms_per_rad: np.ndarray,
    rotor_inertia_kgm2: np.ndarray | float,
) -> np.ndarray:
    """The torque a servo's spring must deliver to follow a planned path [N·m], shape (T, n):

        τ_drive = τ + D·q̇ + J·q̈

    τ the load torque of the planned motion (the feed-forward, what eq 7 takes), D the motor's
    back-EMF damping [N·m·s/rad] and J its reflected rotor inertia [kg·m²], both per joint
    (the simulation's `ServoLaw` / `PartLaw` and armature). With the servo law
    τ_spring = K·(q_cmd − q) − D·q̇ on a rotor of inertia J, the joint follows q only if
    K·(q_cmd − q) = τ_drive, so eq 7 on τ_drive, q_cmd = q + k·τ_drive, is the command that
    keeps it on the plan; on τ alone a moving joint lags by c·D·q̇ (a first-order lag of time
    constant c·D: servo_biped's 1.4 °/(N·m) and 1 N·m·s/rad give 24 ms, a tenth of a walking
    step). For a slow motion (the paper's squats, q̇ ≈ 0) it is eq 7 as the paper writes it."""
    tau = np.asarray(tau_Nm, dtype=float)
    qd = np.asarray(qd_rad_s, dtype=float)
    qdd = np.asarray(qdd_rad_s2, dtype=float)
    if not (tau.shape == qd.shape == qdd.shape) or tau.ndim != 2:
        raise CompensationError(
            f"torques {tau.shape}, speeds {qd.shape} and accelerations {qdd.shape} must all be "
            "(T, n): one value per sample and joint"
        )
    damping = np.broadcast_to(np.asarray(damping_Nms_per_rad, dtype=float), tau.shape[1:])
    inertia = np.broadcast_to(np.asarray(rotor_inertia_kgm2, dtype=float), tau.shape[1:])
    return tau + damping * qd + inertia * qdd


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
