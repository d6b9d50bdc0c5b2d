"""Default planner settings for a robot: the paper's case scaled to the robot's legs.

dircon_biped keeps the paper's numbers (GaitSettings()). Another robot gets them scaled by
dynamic similarity (equal Froude number v²/(g·l)) with the length ratio λ = l / l_paper, l the
base's straight-leg standing height above the soles:
  lengths (step, swing height, clearance) × λ, speeds (touch-down) × √λ; the gait time H × λ^¼
(not Froude's √λ: on servo_biped, λ ≈ 0.31, H = 0.40 s did not converge in 1000 iterations while
0.50–0.60 s converge in ~35).
The torque bound is the smallest URDF effort limit of the planar joints and the speed bound the
smallest URDF velocity limit; where the URDF gives none (0), the paper's 13 N·m scaled by
weight × length, (m l) / (m_paper l_paper), and the paper's 6.28 rad/s, and a note says so.
"""

from __future__ import annotations

import dataclasses
import math

from app.core.collocation.planar_model import PlanarModel
from app.core.collocation.settings import GaitSettings
from app.core.robot.model import RobotModel

PAPER_ROBOT = "dircon_biped"
PAPER_LEG_M = 1.011
"""dircon_biped's base height above the soles with straight legs [m] (Table 1's links)."""
PAPER_MASS_KG = 18.532
"""dircon_biped's mass [kg] (Table 2)."""


@dataclasses.dataclass(frozen=True)
class RobotGaitDefaults:
    settings: GaitSettings
    notes: tuple[str, ...]
    """Where a default is not the robot's own (URDF without limits), one line each."""
    length_ratio: float
    """λ = the robot's leg length / dircon_biped's."""


def robot_gait_defaults(robot: RobotModel | PlanarModel) -> RobotGaitDefaults:
    """Settings for `robot`, with notes on the defaults the URDF could not give."""
    model = robot if isinstance(robot, PlanarModel) else PlanarModel(robot)
    if model.robot.name == PAPER_ROBOT:
        return RobotGaitDefaults(GaitSettings(), (), 1.0)
    paper = GaitSettings()
    ratio = model.standing_height_m / PAPER_LEG_M
    root = math.sqrt(ratio)
    notes = []
    efforts = model.effort_Nm[model.effort_Nm > 0.0]
    if len(efforts) == len(model.effort_Nm):
        tau = float(efforts.min())
    else:
        tau = paper.tau_max_Nm * model.mass_kg * ratio / PAPER_MASS_KG
        notes.append(
            f"the URDF gives no effort limit for some planar joints: |τ| ≤ {tau:.3g} N·m is the "
            "paper's 13 N·m scaled by mass × leg length"
        )
    speeds = model.velocity_radps[model.velocity_radps > 0.0]
    if len(speeds) == len(model.velocity_radps):
        qd = float(speeds.min())
    else:
        qd = paper.qd_max
        notes.append(
            f"the URDF gives no velocity limit for some planar joints: |q̇| ≤ {qd:g} rad/s "
            "is the paper's"
        )
    settings = dataclasses.replace(
        paper,
        H_s=round(paper.H_s * ratio**0.25, 3),
        step_length_m=round(paper.step_length_m * ratio, 4),
        swing_height_m=round(paper.swing_height_m * ratio, 4),
        swing_clearance_m=round(paper.swing_clearance_m * ratio, 4),
        touchdown_speed_max_mps=round(paper.touchdown_speed_max_mps * root, 3),
        tau_max_Nm=round(tau, 3),
        qd_max=round(qd, 3),
    )
    return RobotGaitDefaults(settings.validate(), tuple(notes), ratio)


def default_settings(robot: RobotModel | PlanarModel) -> GaitSettings:
    """The planner's default settings for `robot` (the paper's for dircon_biped)."""
    return robot_gait_defaults(robot).settings
