"""Servo masses in the robot's dynamics: a joint's servo replacing the mass its link counts.

Opt-in. Each actuated joint's servo is taken as a point mass at the joint's origin, carried by
the joint's child body (pinocchio's body of that joint: the output horn side, as a servo
bolted with its case on the child link). The URDF link already counts some servo there —
`counted_kg` (0: none, the new mass is added) — and the chosen servo's `new_kg` replaces it:

    inertia_j ← inertia_j + point(new_kg − counted_kg) at the joint's origin

(pinocchio's inertia sum: masses add, the centre of mass moves to the weighted mean, the
rotational inertia follows the parallel-axis theorem, exact for removing a point mass too).
So the robot's mass changes by Σ_j (new − counted) and its centre of mass by the moved point
masses: a sweep over servos changes the dynamics honestly. A body left with no mass, or an
impossible inertia, is refused naming the joint.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping

import numpy as np
import pinocchio as pin

from app.core.errors import StudioError, refuse_unknown_joints
from app.core.robot.model import RobotModel


class ServoMassError(StudioError):
    """Servo masses that cannot replace the links' (unknown joint, bad figure, no mass left)."""


@dataclasses.dataclass(frozen=True)
class MassSwap:
    """What changed: per joint (robot order) the mass removed and added [kg]."""

    joint_names: tuple[str, ...]
    counted_kg: np.ndarray
    new_kg: np.ndarray
    mass_before_kg: float
    mass_after_kg: float

    def note(self) -> str:
        delta = self.mass_after_kg - self.mass_before_kg
        return (
            f"servo masses replace the links' ({len(self.joint_names)} joint(s)): robot "
            f"{self.mass_before_kg:.3f} kg → {self.mass_after_kg:.3f} kg ({delta:+.3f} kg)"
        )


def _masses(robot: RobotModel, values: Mapping[str, float], what: str) -> np.ndarray:
    refuse_unknown_joints(values, robot.joint_names, ServoMassError, where=what, robot=robot.name)
    out = np.zeros(len(robot.joint_names))
    for i, name in enumerate(robot.joint_names):
        value = float(values.get(name, 0.0))
        if not (math.isfinite(value) and value >= 0.0):
            raise ServoMassError(f"{what} of {name} is {value}; give a finite mass ≥ 0 [kg]")
        out[i] = value
    return out


def with_servo_masses(
    robot: RobotModel,
    new_kg: Mapping[str, float],
    counted_kg: Mapping[str, float] | None = None,
) -> tuple[RobotModel, MassSwap]:
    """A copy of `robot` whose joints' child bodies carry `new_kg` instead of `counted_kg`
    (module docstring); joints not named keep their link as it is."""
    new = _masses(robot, new_kg, "servo mass")
    counted = _masses(robot, counted_kg or {}, "counted servo mass")
    for name in robot.joint_names:
        if name in (counted_kg or {}) and name not in new_kg:
            raise ServoMassError(f"joint {name}: a counted servo mass but no new one")
    model = pin.Model(robot.model)
    for i, name in enumerate(robot.joint_names):
        if name not in new_kg:
            continue
        jid = model.getJointId(name)
        delta = pin.Inertia(float(new[i] - counted[i]), np.zeros(3), np.zeros((3, 3)))
        inertia = model.inertias[jid] + delta
        if not inertia.mass > 0.0:
            raise ServoMassError(
                f"joint {name}: its link ({model.inertias[jid].mass:.4g} kg) less the counted "
                f"servo ({counted[i]:.4g} kg) leaves no mass"
            )
        if np.linalg.eigvalsh(np.asarray(inertia.inertia)).min() < -1e-12:
            raise ServoMassError(f"joint {name}: removing the counted servo leaves an impossible "
                                 "inertia (the servo is not inside the link)")  # fmt: skip
        model.inertias[jid] = inertia
    swap = MassSwap(
        robot.joint_names,
        counted,
        np.where([name in new_kg for name in robot.joint_names], new, 0.0),
        robot.mass_kg,
        float(sum(inertia.mass for inertia in model.inertias)),
    )
    return dataclasses.replace(robot, model=model), swap
