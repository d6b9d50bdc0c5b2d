"""A simulated run drawn over the plan: each sample moved horizontally so that its stance foot
stands where the plan puts that foot.

A simulated robot does not walk exactly the planned path: a sagging leg lands its swing foot
short, a sole slides a little, and after a few steps the whole robot stands centimetres behind
or beside the plan. Drawn where MuJoCo left it, its ghost then stands beside the robot (which
shows the plan) and the posture error that compensation is about cannot be compared. Here every
sample is translated in the floor plane only, by the offset between the plan's and the
simulation's stance foot: the simulated tilt, height and any fall are kept, the drift over the
floor is taken out and reported apart (`OnPlan.drift_m`).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pinocchio as pin

from app.core.motions.trajectory import Trajectory
from app.core.robot.model import RobotModel
from app.core.servo.model import stance_is_right


@dataclasses.dataclass(frozen=True)
class OnPlan:
    q: np.ndarray
    """Simulated configurations moved onto the plan's stance feet, shape (T, nq)."""
    drift_m: np.ndarray
    """Horizontal offset [m] of the simulated stance foot from the plan's, shape (T, 2)
    (x, y in the world): how far the simulated robot walked off the planned path."""

    @property
    def max_drift_m(self) -> float:
        """Largest horizontal distance [m] between a simulated and a planned stance foot."""
        return float(np.max(np.linalg.norm(self.drift_m, axis=1))) if len(self.drift_m) else 0.0


def on_plan_stance(robot: RobotModel, trajectory: Trajectory, q_sim: np.ndarray) -> OnPlan:
    """Each sample of `q_sim` (T, nq) translated in x, y so that its stance foot (the plan's
    contacts, `stance_is_right`) is over the plan's stance foot."""
    q_sim = np.asarray(q_sim, dtype=float)
    out = q_sim.copy()
    drift = np.zeros((len(q_sim), 2))
    if not robot.floating_base or len(robot.feet) != 2:
        return OnPlan(out, drift)
    model, data = robot.model, robot.model.createData()
    frames = [robot.link_frame_ids[foot.link] for foot in robot.feet]
    right = stance_is_right(trajectory.contacts)
    for k in range(min(len(q_sim), trajectory.n_samples)):
        frame = frames[int(right[k])]
        pin.forwardKinematics(model, data, trajectory.q[k])
        planned = pin.updateFramePlacement(model, data, frame).translation[:2].copy()
        pin.forwardKinematics(model, data, q_sim[k])
        simulated = pin.updateFramePlacement(model, data, frame).translation[:2]
        drift[k] = simulated - planned
        out[k, :2] -= drift[k]
    return OnPlan(out, drift)
