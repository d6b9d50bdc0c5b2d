"""Servos sized to the robot: the paper's ideal servo scaled by the robot's m·g·h.

The studio's virtual servo is the spring paper's (Wang et al. 2023): compliance
c₀ = 1.4 °/(N·m) (Table 2's identifiable servos, `papers.TYPICAL_COMPLIANCE_DEG_PER_NM`), a
0.5° dead band (`simulation.files.DEFAULT_BACKLASH_DEG`) and a 6 N·m torque limit (the effort
of servo_biped's leg joints, our model of the paper's 6.6 kg robot, Table 1). On a heavier
robot that servo cannot hold the weight: standing on two ankles of stiffness K = 1/c against
gravity's destabilising stiffness m·g·h (h the CoM's height above the ankles), the robot stands
while 2/c > m·g·h (`app.core.dynamics.stand_stiffness`). Roban S14 (28.7 kg, h ≈ 0.51 m):
m·g·h ≈ 144 N·m/rad against 2/c₀ ≈ 82 N·m/rad from two paper servos: it falls.

The rule: with the size ratio r = (m·g·h)_robot / (m·g·h)_paper,

    c = c₀ / r,        τ_max = τ₀ · r,        dead band unchanged,

so every robot keeps the paper robot's ratio of servo stiffness to gravity's (the same stand
margin, the same sag per unit of weight: c·m·g·h is unchanged) and of torque to its weight's
moments (gravity torques scale as m·g·ℓ, ℓ ∝ h). h is taken at the robot's neutral pose (the
URDF's zero angles, so no IK is needed): the CoM's height above the mean height of the joints
that carry the feet (the ankles). (m·g·h)_paper = PAPER_GRAVITY_NM_PER_RAD, the same measure
on servo_biped (6.6 kg, h = 0.244 m: 15.8 N·m/rad; a test recomputes it).
Numbers: Roban S14 (28.7 kg, h = 0.532 m: 150 N·m/rad), r ≈ 9.5: c ≈ 0.148 °/(N·m),
τ_max ≈ 57 N·m (the audit of issue 26: 0.146 °/(N·m) and 57 N·m). servo_biped: r = 1.
SigmaBan (4.3 kg): r ≈ 0.88, c ≈ 1.6 °/(N·m); dircon_biped (18.5 kg): r ≈ 8.5, c ≈ 0.16.

The torque limit applies to the joints whose URDF gives no effort limit (a robot without servo
data); a URDF's own efforts are the robot's data and stay.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pinocchio as pin

from app.core.papers import TYPICAL_COMPLIANCE_DEG_PER_NM
from app.core.robot.model import RobotModel
from app.core.servo.model import ServoModel

GRAVITY_MPS2 = 9.81
PAPER_MASS_KG = 6.6
"""The spring paper's robot (Table 1: entire robot mass)."""
PAPER_GRAVITY_NM_PER_RAD = 15.82
"""m·g·h of servo_biped (the paper's robot) at its neutral pose [N·m/rad] (module docstring;
tests/core/test_servo_scaling.py recomputes it with pinocchio)."""
PAPER_DEAD_BAND_DEG = 0.5
"""The default virtual servo's dead band [°] (a hobby servo's gear play)."""
PAPER_TORQUE_LIMIT_NM = 6.0
"""servo_biped's leg servos' effort limit [N·m] (its URDF)."""


@dataclasses.dataclass(frozen=True)
class ScaledServo:
    """The paper's servo sized to one robot (module docstring)."""

    robot_name: str
    gravity_Nm_per_rad: float
    """The robot's m·g·h at its neutral pose [N·m/rad]."""
    ratio: float
    """r = m·g·h over the paper robot's [1]."""
    compliance_deg_per_Nm: float
    dead_band_deg: float
    torque_limit_Nm: float

    def text(self) -> str:
        """One line for the user."""
        return (
            f"servos sized to {self.robot_name}: {self.compliance_deg_per_Nm:.3g} °/(N·m), "
            f"{self.dead_band_deg:g}° dead band, {self.torque_limit_Nm:.3g} N·m (the paper's "
            f"{TYPICAL_COMPLIANCE_DEG_PER_NM:g} °/(N·m), {PAPER_TORQUE_LIMIT_NM:g} N·m scaled "
            f"by m·g·h = {self.gravity_Nm_per_rad:.3g} N·m/rad, ×{self.ratio:.2f} the paper "
            "robot's)"
        )


def gravity_stiffness_Nm_per_rad(robot: RobotModel, q: np.ndarray | None = None) -> float:
    """m·g·h [N·m/rad] at q (default: the neutral pose), h the CoM's height above the mean
    height of the feet's parent joints (the ankles). Without feet, h is the CoM's height above
    the lowest joint."""
    model = robot.model
    data = model.createData()
    q = robot.q_neutral if q is None else np.asarray(q, dtype=float)
    com = pin.centerOfMass(model, data, q)  # also runs the forward kinematics
    if robot.feet:
        joints = [model.frames[robot.link_frame_ids[foot.link]].parentJoint for foot in robot.feet]
        base = float(np.mean([data.oMi[j].translation[2] for j in joints]))
    else:
        base = min(float(data.oMi[j].translation[2]) for j in range(1, model.njoints))
    return robot.mass_kg * GRAVITY_MPS2 * max(float(com[2]) - base, 0.0)


def scaled_ideal_servo(robot: RobotModel) -> ScaledServo:
    """The paper's servo sized to `robot` by m·g·h (module docstring)."""
    gravity = gravity_stiffness_Nm_per_rad(robot)
    ratio = gravity / PAPER_GRAVITY_NM_PER_RAD if gravity > 0.0 else 1.0
    return ScaledServo(
        robot_name=robot.name,
        gravity_Nm_per_rad=gravity,
        ratio=ratio,
        compliance_deg_per_Nm=_figures(TYPICAL_COMPLIANCE_DEG_PER_NM / ratio),
        dead_band_deg=PAPER_DEAD_BAND_DEG,
        torque_limit_Nm=_figures(PAPER_TORQUE_LIMIT_NM * ratio),
    )


def _figures(value: float) -> float:
    """Three significant figures, a datasheet's (servo_biped's r = 0.9999 gives 1.4 exactly)."""
    return float(f"{value:.3g}")


def scaled_servo_model(robot: RobotModel, joints: np.ndarray) -> ServoModel:
    """Virtual servos of the scaled compliance and dead band on `joints` (bool per actuated
    joint; `simulation.files.sized_servos`: on the leg joints), the others rigid."""
    scaled = scaled_ideal_servo(robot)
    on = np.asarray(joints, dtype=bool)
    return ServoModel(
        robot.joint_names,
        np.where(on, scaled.compliance_deg_per_Nm, 0.0),
        np.where(on, scaled.dead_band_deg, 0.0),
    )
