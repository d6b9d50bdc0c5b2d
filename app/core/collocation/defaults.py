"""Default planner settings for a robot: a walk scaled to the robot's legs.

dircon_biped keeps the paper's numbers (GaitSettings()). Another robot walks steps a viewer
recognises, sized by its leg length L = the hip-to-sole height in its ready pose (each leg's
top joint above the soles with straight legs, less the ready pose's crouch, READY_CROUCH·L):
  step (one step, half the advance)  = STEP_PER_LEG · L          (0.26 L; the paper: 0.1 L)
  gait time H (two steps)           = 2 · step / √(Fr · g · L)  (a walking speed v of Froude
                                       number Fr = v² / (g L) = FROUDE = 0.05)
so H = 2 · 0.26 / √0.05 · √(L / g) = 2.33 √(L / g): servo_biped (L = 0.296 m) steps 7.7 cm in
0.40 s per two steps, Roban S14 (L = 0.651 m) 16.9 cm in 0.60 s; both solve (servo_biped
from the cold guess in ~30 iterations) and walk (tests/core/test_gait_defaults_walk.py measures the walk's
footholds with pinocchio). 0.26 rather than 0.25: a quarter of the leg with room for rounding.
Before (issue 23), the paper's 0.1 L steps scaled by the leg ratio gave servo_biped 3.1 cm steps.
The swing height and clearance are the paper's scaled by λ = l / l_paper (l the base's
straight-leg standing height above the soles), the touch-down speed by √λ.
The torque bound is the smallest URDF effort limit of the planar joints and the speed bound the
smallest URDF velocity limit; where the URDF gives none (0), the paper's 13 N·m scaled by
weight × length, (m l) / (m_paper l_paper), and the paper's 6.28 rad/s, and a note says so.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pinocchio as pin

from app.core.collocation.planar_model import PlanarModel
from app.core.collocation.settings import GaitSettings
from app.core.posing.ready_pose import READY_CROUCH
from app.core.robot.model import RobotModel

PAPER_ROBOT = "dircon_biped"
PAPER_LEG_M = 1.011
"""dircon_biped's base height above the soles with straight legs [m] (Table 1's links)."""
PAPER_MASS_KG = 18.532
"""dircon_biped's mass [kg] (Table 2)."""
STEP_PER_LEG = 0.26
"""Default step length (half the two-step advance) over the leg length L (issue 23: ≥ 0.25)."""
FROUDE = 0.05
"""Froude number v² / (g L) of the default walking speed v (humans walk at 0.1–0.4)."""


def leg_length_m(model: PlanarModel) -> float:
    """The hip-to-sole height in the ready pose [m]: the mean height of each leg's top joint
    (the first below the floating base) above the soles with straight legs, lowered by the
    ready pose's crouch (READY_CROUCH of it)."""
    robot = model.robot
    pmodel = robot.model
    data = pmodel.createData()
    pin.forwardKinematics(pmodel, data, model.to_full_q(np.zeros(model.nq)))
    base = 1  # the free-flyer joint; the planar base is at z = 0, the soles below
    heights = []
    for foot in robot.feet:
        joint = pmodel.frames[robot.link_frame_ids[foot.link]].parentJoint
        while pmodel.parents[joint] != base:
            joint = pmodel.parents[joint]
        hip_z = data.oMi[joint].translation[2] - data.oMi[base].translation[2]
        heights.append(float(hip_z) + model.standing_height_m)
    return (1.0 - READY_CROUCH) * float(np.mean(heights))


@dataclasses.dataclass(frozen=True)
class RobotGaitDefaults:
    settings: GaitSettings
    notes: tuple[str, ...]
    """Where a default is not the robot's own (URDF without limits), one line each."""
    length_ratio: float
    """λ = the robot's standing height / dircon_biped's."""
    leg_m: float = float("nan")
    """L, the hip-to-sole height in the ready pose [m] (leg_length_m)."""


def robot_gait_defaults(robot: RobotModel | PlanarModel) -> RobotGaitDefaults:
    """Settings for `robot`, with notes on the defaults the URDF could not give."""
    model = robot if isinstance(robot, PlanarModel) else PlanarModel(robot)
    if model.robot.name == PAPER_ROBOT:
        return RobotGaitDefaults(GaitSettings(), (), 1.0, leg_length_m(model))
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
    leg = leg_length_m(model)
    step = STEP_PER_LEG * leg
    settings = dataclasses.replace(
        paper,
        H_s=round(2.0 * step / math.sqrt(FROUDE * model.gravity * leg), 3),
        step_length_m=round(2.0 * step, 4),
        swing_height_m=round(paper.swing_height_m * ratio, 4),
        swing_clearance_m=round(paper.swing_clearance_m * ratio, 4),
        touchdown_speed_max_mps=round(paper.touchdown_speed_max_mps * root, 3),
        tau_max_Nm=round(tau, 3),
        qd_max=round(qd, 3),
    )
    return RobotGaitDefaults(settings.validate(), tuple(notes), ratio, leg)


def default_settings(robot: RobotModel | PlanarModel) -> GaitSettings:
    """The planner's default settings for `robot` (the paper's for dircon_biped)."""
    return robot_gait_defaults(robot).settings
