"""Where each ghost stands at a sample of the current motion (pinocchio configurations).

The plan is the robot itself; the command and the quick estimates stand on the plan's stance
foot (app.core.servo.model); the simulated runs are moved over the floor onto the plan's
stance foot (app.core.simulation.on_plan), computed once per simulation.
"""

from __future__ import annotations

import threading

import numpy as np

from app.core.motions.trajectory import Trajectory
from app.core.robot.model import RobotModel
from app.core.servo.model import Prediction, command_configuration
from app.core.simulation.on_plan import OnPlan, on_plan_stance
from app.studio.simulation_runner import WITH, WITHOUT, Simulation

SIMULATED = {"sim_without": WITHOUT, "sim_with": WITH}
"""Ghost name -> the simulated run it shows."""


class GhostPoses:
    """The ghosts' configurations; keeps the simulated runs moved onto the plan."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._for: Simulation | None = None
        self._on_plan: dict[str, OnPlan] = {}

    def simulated(self, robot: RobotModel, simulation: Simulation) -> dict[str, OnPlan]:
        """Each simulated run on the plan's stance feet (ghost name -> OnPlan)."""
        with self._lock:
            if self._for is not simulation:
                self._on_plan = {
                    ghost: on_plan_stance(robot, simulation.trajectory, simulation.results[label].q)
                    for ghost, label in SIMULATED.items()
                }
                self._for = simulation
            return self._on_plan

    def drift_m(self, robot: RobotModel, simulation: Simulation) -> dict[str, float]:
        """Per simulated run (its label), its stance foot's largest distance from the plan's."""
        on_plan = self.simulated(robot, simulation)
        return {label: on_plan[ghost].max_drift_m for ghost, label in SIMULATED.items()}

    def at(
        self,
        robot: RobotModel,
        trajectory: Trajectory,
        prediction: Prediction,
        simulation: Simulation | None,
        k: int,
    ) -> dict[str, np.ndarray]:
        """Every ghost's configuration at sample k (the simulated ones when `simulation` is
        of this trajectory)."""
        k = int(np.clip(k, 0, trajectory.n_samples - 1))
        poses = {
            "planned": trajectory.q[k],
            "command": command_configuration(robot, trajectory, prediction, k),
            "without": prediction.q_world_uncompensated[k],
            "with": prediction.q_world_compensated[k],
        }
        if simulation is not None and simulation.trajectory is trajectory:
            for ghost, on_plan in self.simulated(robot, simulation).items():
                poses[ghost] = on_plan.q[k]
        return poses
