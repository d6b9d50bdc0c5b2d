"""Where each ghost stands at a sample of the current motion (pinocchio configurations).

The plan is the robot itself; the command and the quick estimates stand on the plan's stance
foot (app.core.servo.model); the simulated runs are the state's simulation moved over the
floor onto the plan's stance foot (`SimulationRecord.on_plan`, computed once per simulation).
"""

from __future__ import annotations

import numpy as np

from app.core.motions.trajectory import Trajectory
from app.core.robot.model import RobotModel
from app.core.servo.model import Prediction, command_configuration
from app.studio.simulation_runner import SimulationRecord


def ghost_poses(
    robot: RobotModel,
    trajectory: Trajectory,
    prediction: Prediction,
    simulation: SimulationRecord | None,
    k: int,
) -> dict[str, np.ndarray]:
    """Every ghost's configuration at sample k (the simulated ones when `simulation` is of
    this trajectory)."""
    k = int(np.clip(k, 0, trajectory.n_samples - 1))
    poses = {
        "planned": trajectory.q[k],
        "command": command_configuration(robot, trajectory, prediction, k),
        "without": prediction.q_world_uncompensated[k],
        "with": prediction.q_world_compensated[k],
    }
    if simulation is not None and simulation.run.trajectory is trajectory:
        for ghost, on_plan in simulation.on_plan.items():
            poses[ghost] = on_plan.q[k]
    return poses
