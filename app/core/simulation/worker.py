"""Simulate in the studio's worker process (`app.jobs.SolverWorker`), without pinocchio there.

The studio prepares the runs (`prepare`, which checks the inputs and raises StudioErrors at
once, in the studio), submits them as one `SimulationJob`, and turns the returned engine runs
into results with `finish`:

    worker = SolverWorker("app.core.simulation.worker:build_simulation_problem")
    job = simulation_job(robot, trajectory, {"without": q_plan, "with": q_cmd}, servo)
    worker.submit(job_id, job, SIMULATION_KEY)
    # progress: callback(job_id, percent, fraction, 0.0); done: callback(job_id, runs)
    results = finish_job(robot, trajectory, job, runs)     # {label: SimulationResult}

A blow-up in the worker arrives as the job's "failed" message (SimulationDiverged's text).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from app.core.simulation.engine import EngineInput, EngineRun, run_engine

if TYPE_CHECKING:
    import numpy as np

    from app.core.motions.trajectory import Trajectory
    from app.core.robot.model import RobotModel
    from app.core.servo.model import ServoModel
    from app.core.simulation.balance_feedback import BalanceGains
    from app.core.simulation.mjcf import SimOptions
    from app.core.simulation.result import SimulationResult
    from app.core.simulation.servo_law import ServoLaw

UNAIDED = " (without balance feedback)"
"""The label suffix of a run's twin without the balance feedback (`simulation_job`)."""
SIMULATION_KEY = "simulation"
"""The structure key of simulation jobs (nothing is cached between them)."""


@dataclasses.dataclass(frozen=True, eq=False)
class SimulationJob:
    """Picklable runs: one engine input per label, all on the same robot and motion."""

    labels: tuple[str, ...]
    inputs: tuple[EngineInput, ...]


class SimulationProblem:
    """`SolvableProblem` for SolverWorker: runs a job's inputs one after the other."""

    def solve(
        self,
        settings: SimulationJob,
        warm_start: Any = None,
        iteration_callback: Callable[[int, float, float], None] | None = None,
    ) -> tuple[EngineRun, ...]:
        """The engine runs, in label order. Progress: iteration_callback(percent, fraction, 0)."""
        n = len(settings.inputs)
        runs = []
        for i, inp in enumerate(settings.inputs):

            def report(fraction: float, i: int = i) -> None:
                if iteration_callback is not None:
                    overall = (i + fraction) / n
                    iteration_callback(round(100 * overall), overall, 0.0)

            runs.append(run_engine(inp, report))
        return tuple(runs)


def build_simulation_problem(structure_key: Any) -> SimulationProblem:
    """SolverWorker's factory ("app.core.simulation.worker:build_simulation_problem")."""
    return SimulationProblem()


def simulation_job(
    robot: RobotModel,
    trajectory: Trajectory,
    commands: dict[str, np.ndarray],
    servo: ServoModel,
    options: SimOptions | None = None,
    law: ServoLaw | None = None,
    balance: BalanceGains | None = None,
    unaided: bool = False,
) -> SimulationJob:
    """Checked, picklable runs (raises SimulationInputError in the caller, not the worker);
    `law` replaces the virtual servos' (servo parts: `part_law.law_with_parts`); `balance`:
    the balance feedback's gains (None: off); `unaided` with `balance`: each run also without
    the feedback, labelled `label + UNAIDED` (the verdicts side by side, one click)."""
    from app.core.simulation.mjcf import build_sim_model
    from app.core.simulation.run import prepare

    sim = build_sim_model(robot, options)
    runs = [(label, balance) for label in commands]
    if unaided and balance is not None:
        runs += [(label + UNAIDED, None) for label in commands]
    inputs = tuple(
        prepare(
            robot, trajectory, commands[label.removesuffix(UNAIDED)], servo, options, sim=sim,
            law=law, balance=gains,
        )
        for label, gains in runs
    )  # fmt: skip
    return SimulationJob(tuple(label for label, _gains in runs), inputs)


def finish_job(
    robot: RobotModel,
    trajectory: Trajectory,
    job: SimulationJob,
    runs: tuple[EngineRun, ...],
) -> dict[str, SimulationResult]:
    """The typed results of a job's runs, by label."""
    from app.core.simulation.run import finish

    return {
        label: finish(robot, trajectory, inp, run, label)
        for label, inp, run in zip(job.labels, job.inputs, runs, strict=True)
    }
