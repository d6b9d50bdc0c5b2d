"""The paper's servo numbering and coefficients, put on a robot's joints.

The paper numbers its 12 leg servos 1–6 on the left leg and 7–12 on the right leg, each leg from
the pelvis down: hip yaw, hip roll, hip pitch, knee, ankle pitch, ankle roll (`LEG_ROLES`).
`servo_joint_names` finds those joints on any robot with two 6-joint legs (see there), and the
presets `paper_table3_preset` / `paper_table2_preset` put the paper's coefficients on them.
The coefficients are copied with the signs printed for Roban: they carry Roban's joint and
torque sign conventions (same axes on both legs, like `servo_biped`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from itertools import permutations

import numpy as np

from app.core.papers import TABLE3_K_DEG_PER_NM as PAPER_TABLE3_K_DEG_PER_NM
from app.core.papers import TYPICAL_COMPLIANCE_DEG_PER_NM
from app.core.robot.model import RobotModel
from app.core.servo.compensation import (
    PAPER_PHI_DEG,
    CompensationError,
    CompensationParams,
    disabled_params,
)
from app.core.servo.scaling import scaled_ideal_servo

LEG_ROLES = ("hip_yaw", "hip_roll", "hip_pitch", "knee", "ankle_pitch", "ankle_roll")
"""The paper's servo order within a leg; servo i (1–12) is LEG_ROLES[(i - 1) % 6] of the left
(1–6) or right (7–12) leg."""
MIN_AXIS_ALIGNMENT = 0.5
"""A joint takes a role (roll about x, pitch about y, yaw about z) only when |axis · that
direction| reaches this at q = 0 (Roban S14's 45°-tilted hip joint has 0.71)."""


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
    the printed digits (`app.core.servo.calibration.check_table2`); where they disagree (servo 11,
    printed −722.91, ten times its row's −72.29) the row's value is used and a note says so.
    """
    from app.core.servo.calibration import check_table2

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


def uniform_preset(
    robot: RobotModel, k_deg_per_Nm: float = TYPICAL_COMPLIANCE_DEG_PER_NM
) -> CompensationParams:
    """The same k on every leg joint (eq 7): a starting point where the paper's Roban-specific
    signs do not apply. The default is the compliance of the paper's identifiable servos."""
    legs = {name for chain in _leg_chains(robot) for name, _ in chain}
    names = robot.joint_names
    return CompensationParams(
        names,
        np.array([k_deg_per_Nm if name in legs else 0.0 for name in names]),
        np.zeros(len(names)),
        np.array([name in legs for name in names]),
        "command",
        (
            f"k = {k_deg_per_Nm:g} °/(N·m) on every leg joint ("
            + (
                "Table 2's identifiable servos)"
                if k_deg_per_Nm == TYPICAL_COMPLIANCE_DEG_PER_NM
                else "the paper's servo sized to the robot by m·g·h)"
            ),
        ),
    )


@dataclasses.dataclass(frozen=True)
class Preset:
    """A named set of coefficients that can be put on any robot it fits."""

    key: str
    """Short name for the CLI (`--preset KEY`) and project files."""
    label: str
    """What the studio's dropdown shows."""
    build: Callable[[RobotModel], CompensationParams]


PRESETS: dict[str, Preset] = {
    preset.key: preset
    for preset in (
        Preset(
            "uniform",
            f"uniform k = the servos' compliance ({TYPICAL_COMPLIANCE_DEG_PER_NM} °/(N·m) on the "
            "paper's robot, sized to the robot by m·g·h)",
            lambda robot: uniform_preset(robot, scaled_ideal_servo(robot).compliance_deg_per_Nm),
        ),
        Preset("table3", "paper Table 3 (servos 2, 3, 8, 9)", paper_table3_preset),
        Preset(
            "table3_clearance",
            f"paper Table 3 + clearance φ = {PAPER_PHI_DEG:g}°",
            lambda robot: paper_table3_preset(robot, clearance=True),
        ),
        Preset("table2", "paper Table 2 (standing)", paper_table2_preset),
        Preset("none", "none", lambda robot: disabled_params(robot.joint_names)),
    )
}
"""Every preset, in the order the studio offers them; the first is the studio's default."""


def preset_params(key: str, robot: RobotModel) -> CompensationParams:
    """The preset `key` put on the robot's joints (CompensationError if it does not fit)."""
    if key not in PRESETS:
        raise CompensationError(f"no preset {key!r}; the presets are {', '.join(PRESETS)}")
    return PRESETS[key].build(robot).for_joints(robot.joint_names)
