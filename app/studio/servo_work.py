"""The motion's work as a project keeps it: torques, coefficients and virtual servos, the
servo parts per joint, and the last simulation, read from and restored into the state (the project session's `HoldsWork`
part; the sessions that show them follow the state's signals)."""

from __future__ import annotations

from typing import Any

from app.core.projects.project import Project
from app.core.simulation.drive import DEFAULT_COMPENSATED_TORQUE
from app.core.simulation.result import SimulationResult
from app.core.simulation.worker import SimulationJob
from app.studio.simulation_runner import WITH, WITHOUT, Simulation, simulation_record
from app.studio.state import StudioState


class ServoWork:
    def __init__(self, state: StudioState) -> None:
        self._state = state

    def snapshot(self) -> dict[str, Any]:
        with self._state.lock:
            state = self._state
            record, coefficients = state.work.simulation, state.work.coefficients
            runs: tuple[SimulationResult, ...] = ()
            if record is not None and record.run.trajectory is state.trajectory:
                runs = (record.run.results[WITHOUT], record.run.results[WITH])
            return {
                "feedforward": state.work.torques,
                "compensation": coefficients.params if coefficients is not None else None,
                "servo": coefficients.servo if coefficients is not None else None,
                "compensation_torque": (
                    coefficients.torque if coefficients is not None else DEFAULT_COMPENSATED_TORQUE
                ),
                "servo_parts": state.work.parts,
                "simulation": runs,
                "simulation_stale": record.stale if runs and record is not None else False,
                "simulation_wall_s": record.run.waited_s if runs and record is not None else None,
            }

    def restore(self, project: Project) -> None:
        """The project's coefficients, servos, torques and last simulation; called once its
        robot and motion are installed."""
        with self._state.lock:
            state = self._state
            robot, trajectory, current = state.robot, state.trajectory, state.work.coefficients
            parts = project.servo_parts
            if current is not None and parts is not None:
                state.work.set_parts(
                    parts,
                    project.compensation or current.params,
                    project.servo or current.servo,
                    "project",
                    project.compensation_torque,
                )
            elif current is not None and (
                project.compensation is not None or project.servo is not None
            ):
                state.work.set_coefficients(
                    project.compensation or current.params,
                    project.servo or current.servo,
                    "project",
                    project.compensation_torque,
                )
            if project.feedforward is None or robot is None or trajectory is None:
                return
            state.work.set_torques(project.feedforward, trajectory)
            if len(project.simulation) == 2:
                without, with_ = project.simulation
                simulation = Simulation(
                    job_id="project",
                    robot=robot,
                    trajectory=trajectory,
                    job=SimulationJob((), ()),
                    started_s=0.0,
                    results={WITHOUT: without, WITH: with_},
                    waited_s=project.simulation_wall_s,
                )
                stale = project.simulation_stale
                state.work.set_simulation(simulation_record(simulation, stale, "project"))
