"""The servo of each joint as the studio and its projects keep it: the ideal (virtual) servo,
or a catalogue servo with its firmware settings (`Project.servo_parts`).

Only the choice is kept (catalogue keys and settings, None where the record's own value is
taken; the fit each part runs; the battery and *Size servos*' stand margin and sag bound); the
parts it names are made from the catalogue with the same checks as a servo.toml
(`app.core.servo.parts.parts_from_mapping`: kp within the firmware's range, positive voltage
and current limit, a dead band of 0 … 10°, a servo the simulation can run; a part rated by a
continuous point, without a kp law, a stiffness K > 0 in place of kp), so a project's hostile
values are refused with the same one line.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any, Literal

import numpy as np

from app.core.errors import StudioError
from app.core.servo.catalogue import ServoCatalogueError, ServoRecord
from app.core.servo.compensation import CompensationParams
from app.core.servo.kp_sizing import (
    MAX_SAG_DEG,
    STAND_MARGIN,
    check_max_sag,
    check_stand_margin,
    fit_of,
    kp_of,
)
from app.core.servo.model import ServoModel
from app.core.servo.parts import ServoParts, ServoPartsError, parts_from_mapping
from app.core.servo.sizing import JointSizing
from app.core.servo.user_files import UserServoFile, with_user_files

IDEAL = ""
"""The ideal servo: the virtual compliance and dead band of the Compensation panel."""
SETTINGS = ("kp", "vin_V", "current_limit_A", "dead_band_deg", "stiffness_Nm_per_rad")


@dataclasses.dataclass(frozen=True)
class JointServo:
    """One joint's servo; a setting left None takes the record's (its [firmware], its
    published backlash)."""

    servo: str = IDEAL
    """Catalogue key, or IDEAL."""
    kp: float | None = None
    vin_V: float | None = None
    current_limit_A: float | None = None
    dead_band_deg: float | None = None
    friction_model: Literal["m1", "m6"] = "m1"
    stiffness_Nm_per_rad: float | None = None
    """A part without a kp law (rated by a continuous point): the stiffness K its P loop is
    tuned to, in place of kp (servo.toml's `stiffness_Nm_per_rad`)."""

    @property
    def is_ideal(self) -> bool:
        return self.servo == IDEAL


@dataclasses.dataclass(frozen=True)
class ServoChoice:
    """A servo per actuated joint, in the robot's joint order, and the battery pack the
    energy figures use."""

    joint_names: tuple[str, ...]
    joints: tuple[JointServo, ...]
    battery_Wh: float | None = None
    """A pack's usable energy [Wh] for the minutes of the motion repeated; None: not said."""
    user_servos: tuple[UserServoFile, ...] = ()
    """The user's own servo files (TOML texts), beside the built-in catalogue; read and
    checked again wherever the choice is resolved (app.core.servo.user_files)."""
    stand_margin: float = STAND_MARGIN
    """*Size servos*' stand margin (app.core.servo.kp_sizing, the CLI's --stand-margin); the
    default in files saved before it was kept."""
    max_sag_deg: float = MAX_SAG_DEG
    """*Size servos*' bound on a joint's sag [°] (the CLI's --max-sag-deg)."""

    def joint(self, name: str) -> JointServo:
        return self.joints[self.joint_names.index(name)]

    def with_joint(self, name: str, servo: JointServo) -> ServoChoice:
        i = self.joint_names.index(name)
        return dataclasses.replace(self, joints=(*self.joints[:i], servo, *self.joints[i + 1 :]))

    @property
    def chosen(self) -> tuple[str, ...]:
        """The joints given a catalogue servo."""
        return tuple(
            n for n, j in zip(self.joint_names, self.joints, strict=True) if not j.is_ideal
        )


def ideal_choice(joint_names: Sequence[str]) -> ServoChoice:
    """Every joint on the ideal servo."""
    return ServoChoice(tuple(joint_names), tuple(JointServo() for _ in joint_names))


def simulatable(catalogue: dict[str, ServoRecord]) -> dict[str, ServoRecord]:
    """The records the simulation can run as parts: an identified motor model and firmware."""
    return {k: r for k, r in catalogue.items() if r.firmware is not None and r.fit("m1")}


def runnable(catalogue: dict[str, ServoRecord]) -> dict[str, ServoRecord]:
    """The records a joint can run as a part: those `simulatable`, and those rated by a
    continuous point (no kp law: run at a stated stiffness, app.core.servo.rated_point)."""
    law = simulatable(catalogue)
    return {k: r for k, r in catalogue.items() if k in law or r.rated is not None}


def sized_servo(joint: JointSizing) -> JointServo:
    """The servo *Size servos* gives `joint`: the ideal one where no servo holds it, else the
    servo chosen with its kp on the fit it was chosen on, or, for a part without a kp law,
    the stiffness stated for it (`KpChoice.stated_Nm_per_rad`)."""
    if joint.choice is None:
        return JointServo()
    stiffness = joint.check(joint.choice).stiffness
    if stiffness is not None and stiffness.stated:
        return JointServo(joint.choice, stiffness_Nm_per_rad=stiffness.stated_Nm_per_rad)
    return JointServo(joint.choice, kp=kp_of(joint), friction_model=fit_of(joint))


def joint_mapping(servo: JointServo) -> dict[str, Any]:
    """A servo.toml [joints.<name>] table of one joint's servo."""
    table: dict[str, Any] = {"servo": servo.servo, "friction_model": servo.friction_model}
    table.update({n: getattr(servo, n) for n in SETTINGS if getattr(servo, n) is not None})
    return table


def choice_parts(
    choice: ServoChoice,
    joint_names: Sequence[str],
    catalogue: dict[str, ServoRecord],
    where: str = "servo parts",
) -> ServoParts | None:
    """The checked parts of the chosen joints (None when every joint is ideal); raises
    ServoPartsError naming the field for another robot's joints, a bad battery figure, an
    unknown servo or a setting out of range."""
    if tuple(choice.joint_names) != tuple(joint_names) or len(choice.joints) != len(joint_names):
        raise ServoPartsError(f"{where}: they are for another robot's joints")
    pack = choice.battery_Wh
    if pack is not None and not (math.isfinite(pack) and 0.0 < pack <= 1.0e5):
        raise ServoPartsError(f"{where}: battery_Wh is {pack:g}; give 0 < Wh ≤ 100000")
    check_sizing_bounds(choice, where)
    offered = offered_catalogue(choice, catalogue, where)
    chosen = choice.chosen
    if not chosen:
        return None
    data = {"joints": {name: joint_mapping(choice.joint(name)) for name in chosen}}
    return parts_from_mapping(data, chosen, offered, where)


def check_sizing_bounds(choice: ServoChoice, where: str = "servo parts") -> None:
    """ServoPartsError naming a stand margin or sag bound *Size servos* cannot use (the CLI's
    checks: app.core.servo.kp_sizing)."""
    try:
        check_stand_margin(choice.stand_margin)
        check_max_sag(choice.max_sag_deg)
    except StudioError as error:
        raise ServoPartsError(f"{where}: {error}") from None


def sizing_fits(choice: ServoChoice) -> dict[str, str]:
    """The fit each joint's part runs now ("m1" or "m6", by joint name): *Size servos* chooses
    kp on it (app.core.servo.kp_sizing.part_fit)."""
    return {n: j.friction_model for n, j in zip(choice.joint_names, choice.joints, strict=True)}


def offered_catalogue(
    choice: ServoChoice, catalogue: dict[str, ServoRecord], where: str = "servo parts"
) -> dict[str, ServoRecord]:
    """The catalogue with the choice's user servo files; ServoPartsError naming a bad file."""
    try:
        return with_user_files(catalogue, choice.user_servos)
    except ServoCatalogueError as error:
        raise ServoPartsError(f"{where}: user servos: {error}") from None


def with_parts(
    params: CompensationParams,
    servo: ServoModel,
    parts: ServoParts | None,
    joints: Sequence[str] | None = None,
) -> tuple[CompensationParams, ServoModel]:
    """The coefficients and virtual servos that follow from the parts on their joints (those
    of `joints` only, when given: the joints whose servo just changed, so that a k edited on
    another part's joint stays): the servo's true compliance 1/K and dead band (the quick
    estimate's), eq 7's k = 1/K and the joint compensated; φ, the clearance sign and every
    other joint as they are."""
    if parts is None:
        return params, servo
    if joints is not None:
        parts = ServoParts(tuple(p for p in parts.parts if p.joint in joints))
        if not parts.parts:
            return params, servo
    names = params.joint_names
    where = [names.index(name) for name in parts.joint_names]
    compliance = np.array(servo.compliance_deg_per_Nm, dtype=float)
    backlash = np.array(servo.backlash_deg, dtype=float)
    k = np.array(params.k_deg_per_Nm, dtype=float)
    enabled = np.array(params.enabled, dtype=bool)
    for i, part in zip(where, parts.parts, strict=True):
        compliance[i] = k[i] = part.compliance_deg_per_Nm
        backlash[i] = part.dead_band_deg
        enabled[i] = True
    note = "k = 1/K of the servo parts on " + ", ".join(parts.joint_names)
    return (
        dataclasses.replace(
            params,
            k_deg_per_Nm=k,
            enabled=enabled,
            notes=(*(n for n in params.notes if not n.startswith("k = 1/K")), note),
        ),
        dataclasses.replace(servo, compliance_deg_per_Nm=compliance, backlash_deg=backlash),
    )


def take_joints(
    params: CompensationParams,
    servo: ServoModel,
    source: tuple[CompensationParams | None, ServoModel | None],
    joints: Sequence[str],
) -> tuple[CompensationParams, ServoModel]:
    """`params` and `servo` with the k, enabled, compliance and dead band of `joints` taken
    from `source` (an earlier state of the same robot's coefficients; a None part is skipped)."""
    old_params, old_servo = source
    names = params.joint_names
    where = [names.index(name) for name in joints]
    if old_params is not None and old_params.joint_names == names:
        k, enabled = np.array(params.k_deg_per_Nm), np.array(params.enabled)
        k[where], enabled[where] = old_params.k_deg_per_Nm[where], old_params.enabled[where]
        params = dataclasses.replace(params, k_deg_per_Nm=k, enabled=enabled)
    if old_servo is not None and old_servo.joint_names == servo.joint_names:
        compliance, backlash = np.array(servo.compliance_deg_per_Nm), np.array(servo.backlash_deg)
        compliance[where] = old_servo.compliance_deg_per_Nm[where]
        backlash[where] = old_servo.backlash_deg[where]
        servo = dataclasses.replace(servo, compliance_deg_per_Nm=compliance, backlash_deg=backlash)
    return params, servo
