"""Simulate in the studio's worker process (`app.jobs.SolverWorker`), without pinocchio there.

The studio prepares the runs (`prepare`, which checks the inputs and raises StudioErrors at
once, in the studio), submits them as one `SimulationJob`, and turns the returned engine runs
into results with `finish`:

    worker = SolverWorker("app.core.simulation.worker:build_simulation_problem")
    job = simulation_job(robot, trajectory, {"without": q_plan, "with": q_cmd}, servo)  # run
    worker.submit(job_id, job, SIMULATION_KEY)
    # progress: callback(job_id, percent, fraction, 0.0); done: callback(job_id, runs)
    results = finish_job(robot, trajectory, job, runs)     # run: {label: SimulationResult}

A blow-up in the worker arrives as the job's "failed" message (SimulationDiverged's text).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from app.core.simulation.engine import EngineInput, EngineRun, run_engine

if TYPE_CHECKING:
    pass

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
