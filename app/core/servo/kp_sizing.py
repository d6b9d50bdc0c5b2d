"""Sizing chooses kp too: per joint the smallest firmware kp whose stiffness keeps the robot
standing and every motion's sag within a bound.

A part's static stiffness K = kt·vin·error_gain·kp/R (`motor_law`) grows with kp, so per servo
and joint the kp chosen is the smallest whole kp in 1 … kp_max (the record's control table,
else `parts.KP_MAX`) with K ≥ K_need. kt and R are those of the fit the joint's part runs
(`part_fit`: m1 by default, m6 where the joint's servo.toml or project asks it and the record
has it; each fit identifies its own kt and R, so an MX-64 on m6 is 1.7× stiffer per kp):

    K_need  = max(K_stand, K_sag)
    K_stand = (1 + stand_margin) · K*         on the leg joints (0 on the others)
    K_sag   = (max over the works and samples of |τ_j| + τ_f) / max_sag

K* is the stand check's (app.core.dynamics.stand_stiffness) uniform leg stiffness at the
standing pose: with every leg servo at 1/K* the linearised balance's Hessian H turns
indefinite. H only stiffens as any one servo stiffens (Gᵀ·diag(K)·G grows), so every leg servo
at K ≥ K* stands: a rule per joint (each joint sized by itself), sufficient, not necessary
(a hip yaw could be softer). With the margin the robot still stands with every leg stiffness
divided by (1 + stand_margin). The sag is the spring's quasi-static deflection |τ|/K under
the load and the servo's own friction at rest τ_f (the torque the P loop must overcome before the
joint moves at all: m1's friction_base; m6's budget at rest holding the load |τ|,
friction_base + friction_stribeck + |τ|·(λ_e + λ_m + λ_es + λ_ms), `static_friction_Nm`); a
dead band comes on top (eq 23's φ).

Where no kp in range gives K_need, that servo does not hold the joint (the next one is
taken); where no servo does, the joint is unsized and says why. A record without a motor law
(no firmware constants) cannot be checked: it stays a candidate, said in the notes. A servo
rated by a continuous point (app.core.servo.rated_point: no published conversion of its P gain)
has no kp: it is a position servo stiff as the joint needs, K_need stated (rounded up to a
whole N·m/rad) for its P gain to be tuned to, said in the notes.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Literal

import numpy as np

from app.core.dynamics.stand_stiffness import StandCheckError, stand_check
from app.core.errors import StudioError
from app.core.motions.trajectory import Trajectory
from app.core.robot.model import RobotModel
from app.core.servo.catalogue import ServoRecord
from app.core.servo.kp_choice import KpChoice
from app.core.servo.motor_law import FrictionM1, FrictionM6, m6_budget
from app.core.servo.parts import FRICTION_MODELS, KP_MAX
from app.core.servo.sizing import (
    CONTINUOUS_FRACTION_OF_STALL,
    Criterion,
    JointSizing,
    Sizing,
    SizingError,
    cost,
)
from app.core.servo.sizing_work import Work, size_works

STAND_MARGIN = 0.5
"""Default: the robot still stands with every leg servo 1.5× softer than chosen."""
MAX_STAND_MARGIN = 10.0
"""The largest stand margin taken: leg servos 11× stiffer than standing needs (a safety factor
past any a design asks; a larger one is a typing slip)."""
MAX_SAG_DEG = 2.0
"""Default bound on a joint's quasi-static sag (|τ| + τ_f)/K over every motion [°]. Roban S14
standing uncompensated on parts sized with 5° (its knees sagging 3.3°) fell in the first
0.4 s of a CoM shift; with 2° it stays up (with eq 7 both do)."""


def check_stand_margin(value: float) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise SizingError(f"stand margin is {value!r}; give a finite number ≥ 0")
    if not 0.0 <= value <= MAX_STAND_MARGIN:
        raise SizingError(
            f"stand margin is {value:g}; give a number in [0, {MAX_STAND_MARGIN:g}] "
            "(0.5: 50 % stiffer than standing needs)"
        )
    return float(value)


def check_max_sag(value: float) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise SizingError(f"max sag is {value!r}; give a finite number of degrees > 0")
    if not 0.0 < value <= 90.0:
        raise SizingError(f"max sag is {value:g}°; give a number of degrees in (0, 90]")
    return float(value)


@dataclasses.dataclass(frozen=True, eq=False)
class StiffnessNeed:
    """The stiffness each joint needs (module docstring), in the robot's joint order."""

    joint_names: tuple[str, ...]
    stand_Nm_per_rad: np.ndarray
    """(n,): (1 + stand_margin)·K* on the leg joints, 0 elsewhere (inf: cannot stand)."""
    peak_torque_Nm: np.ndarray
    """(n,): the largest |τ| over the works."""
    peak_work: tuple[str, ...]
    """The work of each joint's largest |τ|."""
    stand_margin: float
    max_sag_deg: float
    leg_Nm_per_rad: float | None
    """K* (margin not included); None where the stand check does not apply."""
    note: str
    """How the stand need was found (pose, K*), or why there is none."""

    def to_json(self) -> dict[str, object]:
        return {
            "stand_margin": self.stand_margin,
            "max_sag_deg": self.max_sag_deg,
            "leg_stiffness_to_stand_Nm_per_rad": self.leg_Nm_per_rad,
            "stand_note": self.note,
        }


def standing_pose(robot: RobotModel, trajectory: Trajectory | None) -> np.ndarray:
    """The motion's first pose where both feet are down, else the robot's ready pose."""
    if trajectory is not None and trajectory.contacts[0, 0] and trajectory.contacts[0, 1]:
        return np.array(trajectory.q[0])
    from app.core.posing.ready_pose import ready_pose

    return ready_pose(robot).q


def stiffness_need(
    robot: RobotModel,
    q_stand: np.ndarray,
    works: dict[str, Work],
    stand_margin: float = STAND_MARGIN,
    max_sag_deg: float = MAX_SAG_DEG,
) -> StiffnessNeed:
    """Each joint's K_need (module docstring) at the standing pose `q_stand` over `works`."""
    stand_margin, max_sag_deg = check_stand_margin(stand_margin), check_max_sag(max_sag_deg)
    n = robot.n_actuated
    peaks = np.zeros(n)
    where = [""] * n
    for label, work in works.items():
        tau = np.abs(np.asarray(work.torque_Nm, dtype=float))
        if len(tau) == 0:
            continue
        top = tau.max(axis=0)
        for j in np.flatnonzero(top > peaks):
            peaks[j], where[j] = top[j], label
    stand = np.zeros(n)
    leg: float | None = None
    try:
        check = stand_check(robot, q_stand, np.zeros(n))
    except (StandCheckError, StudioError) as error:
        note = f"no stand need: {error}"
    else:
        limit = check.max_leg_compliance_deg_per_Nm
        if limit is None:
            leg, note = math.inf, "cannot stand even on rigid leg servos at the standing pose"
        elif math.isinf(limit):
            leg, note = 0.0, "stands on any leg servos at the standing pose"
        else:
            leg = 1.0 / math.radians(limit)
            note = (
                f"to stand, every leg servo needs K ≥ {leg:.3g} N·m/rad (the stand check's "
                f"uniform leg compliance {limit:.3g} °/(N·m)), × {1 + stand_margin:g} with the "
                f"stand margin; gravity m·g·h = {check.gravity_Nm_per_rad:.3g} N·m/rad"
            )
        stand[list(check.leg_joints)] = (1.0 + stand_margin) * leg
    return StiffnessNeed(
        tuple(robot.joint_names), stand, peaks, tuple(where), stand_margin, max_sag_deg, leg, note
    )


def part_fit(record: ServoRecord, asked: str = "m1") -> str:
    """The fit a part of `record` runs where `asked` ("m1", "m6") is asked: the asked one
    where the record has it, else m1 (a record without an m6 fit runs m1)."""
    if asked not in FRICTION_MODELS:
        raise SizingError(f"friction model {asked!r}; give one of {', '.join(FRICTION_MODELS)}")
    return asked if record.fit(asked) is not None else "m1"


def stiffness_per_kp(record: ServoRecord, fit: str = "m1") -> float | None:
    """K per unit of kp [N·m/rad]: kt·vin·error_gain/R of `fit`'s kt and R; None without a
    law (no firmware constants, or no such fit)."""
    law = record.law(fit)
    if law is None:
        return None
    motor, firmware = law
    return motor.kt_Nm_per_A * firmware.vin_V * firmware.error_gain / motor.R_ohm


def static_friction_Nm(record: ServoRecord, fit: str = "m1", load_Nm: float = 0.0) -> float:
    """The friction at rest [N·m] of `fit` holding `load_Nm` (module docstring; 0 without a
    fit): m1's friction_base, m6's budget at q̇ = 0 with the motor torque opposing the load."""
    found = record.fit(fit)
    friction = None if found is None else found.friction
    if isinstance(friction, FrictionM6):
        return float(m6_budget(friction, abs(load_Nm), -abs(load_Nm), 0.0)[0])
    return friction.friction_base_Nm if isinstance(friction, FrictionM1) else 0.0


def kp_max(record: ServoRecord) -> float:
    """The top of the firmware's kp range: the record's, else parts.KP_MAX."""
    top = None if record.firmware is None else record.firmware.kp_max
    return KP_MAX if top is None else top


def choose_kp(
    record: ServoRecord, need: StiffnessNeed, joint: int, asked_fit: str = "m1"
) -> KpChoice:
    """The smallest whole kp in 1 … kp_max of `record` whose K reaches joint `joint`'s need,
    K and friction those of the fit its part runs (`part_fit` of `asked_fit`)."""
    fit = part_fit(record, asked_fit)
    per_kp, top = stiffness_per_kp(record, fit), kp_max(record)
    stand = float(need.stand_Nm_per_rad[joint])
    peak = float(need.peak_torque_Nm[joint])
    friction = static_friction_Nm(record, fit, peak)
    sag = (peak + friction) / math.radians(need.max_sag_deg)
    needed = max(stand, sag)
    if not record.kp_law:
        top = math.inf if record.rated is None else record.rated.p_gain_max
        stated = math.isfinite(needed)  # inf: cannot stand on any servo
        return KpChoice(
            None, top, None, needed, stand, sag, peak, friction, need.max_sag_deg, fit, stated
        )
    kp = None
    if per_kp is not None and math.isfinite(needed):
        kp = max(1.0, float(math.ceil(needed / per_kp)))
        if (kp - 1.0) >= 1.0 and (kp - 1.0) * per_kp >= needed:  # rounding: a step less does
            kp -= 1.0
        if kp > top:
            kp = None
    return KpChoice(
        kp,
        top,
        per_kp,
        needed,
        stand,
        sag,
        peak,
        friction,
        need.max_sag_deg,
        fit,
    )


def with_stiffness(
    sizing: Sizing,
    need: StiffnessNeed,
    catalogue: dict[str, ServoRecord],
    fits: Mapping[str, str] | None = None,
) -> Sizing:
    """`sizing` with each candidate's kp (`choose_kp`) and the choice made again: the least
    `by` among the servos that hold the torque, the heat and the stiffness. `fits`: the fit
    each joint's part runs, by joint name ("m1" where not given)."""
    if [j.joint for j in sizing.joints] != list(need.joint_names):
        raise SizingError("the stiffness need is for other joints than the sizing's")
    asked = dict(fits or {})
    unknown = sorted(set(asked) - set(need.joint_names))
    if unknown:
        raise SizingError(f"friction model asked for {unknown[0]!r}, not a joint of the robot")
    joints = []
    for j, joint in enumerate(sizing.joints):
        fit = asked.get(joint.joint, "m1")
        checks = tuple(
            dataclasses.replace(c, stiffness=choose_kp(catalogue[c.servo], need, j, fit))
            for c in joint.checks
        )
        ranked = sorted(
            (c for c in checks if c.holds),
            key=lambda c: (cost(catalogue[c.servo], sizing.by), c.servo),
        )
        joints.append(JointSizing(joint.joint, ranked[0].servo if ranked else None, checks))
    unchecked = (
        sorted(
            {
                c.servo
                for c in sizing.joints[0].checks
                if stiffness_per_kp(catalogue[c.servo]) is None and catalogue[c.servo].kp_law
            }
        )
        if sizing.joints
        else []
    )
    notes = [need.note]
    fallback = sorted(
        {
            c.servo
            for joint in joints
            for c in joint.checks
            if asked.get(joint.joint, "m1") != "m1"
            and c.stiffness is not None
            and c.stiffness.fit == "m1"
        }
    )
    if fallback:
        notes.append(f"no m6 fit: {', '.join(fallback)} sized on m1 where m6 was asked")
    stated = sorted(
        {j.choice for j in joints if j.choice is not None and not catalogue[j.choice].kp_law}
    )
    if stated:
        notes.append(
            f"no kp law for {', '.join(stated)} (rated by a continuous point; the P gain's "
            "conversion is not published): each joint's stiffness K is stated, the need rounded "
            "up; tune the P gain to give it"
        )
    if unchecked:
        notes.append(
            f"stiffness not checked for {', '.join(unchecked)} (no firmware constants: kp and "
            "K unknown)"
        )
    return dataclasses.replace(
        sizing,
        joints=tuple(joints),
        notes=(*sizing.notes, *notes),
        stiffness=need.to_json(),
    )


def kp_of(joint: JointSizing) -> float | None:
    """The kp the sizing chose for `joint`'s servo (None: no servo, or none checked)."""
    if joint.choice is None:
        return None
    stiffness = joint.check(joint.choice).stiffness
    return None if stiffness is None else stiffness.kp


def fit_of(joint: JointSizing) -> Literal["m1", "m6"]:
    """The fit the sizing chose `joint`'s kp on: the one its part is to run ("m1" where no
    servo was chosen or its stiffness was not checked)."""
    stiffness = None if joint.choice is None else joint.check(joint.choice).stiffness
    return "m6" if stiffness is not None and stiffness.fit == "m6" else "m1"


def size_with_kp(
    robot: RobotModel,
    works: dict[str, Work],
    duration_s: float,
    catalogue: dict[str, ServoRecord],
    margin: float = 0.3,
    by: Criterion = "mass",
    continuous_fraction: float = CONTINUOUS_FRACTION_OF_STALL,
    trajectory: Trajectory | None = None,
    stand_margin: float = STAND_MARGIN,
    max_sag_deg: float = MAX_SAG_DEG,
    fits: Mapping[str, str] | None = None,
) -> Sizing:
    """Torque, heat (`size_works`) and stiffness (`with_stiffness`, each joint on the fit of
    `fits`, m1 where not given) at the standing pose of `trajectory` (its first sample with
    both feet down, else the ready pose): the CLI's `size` and the studio's *Size servos*."""
    need_args = (check_stand_margin(stand_margin), check_max_sag(max_sag_deg))
    sizing = size_works(
        robot.joint_names, works, duration_s, catalogue, margin, by, continuous_fraction
    )
    need = stiffness_need(robot, standing_pose(robot, trajectory), works, *need_args)
    return with_stiffness(sizing, need, catalogue, fits)
