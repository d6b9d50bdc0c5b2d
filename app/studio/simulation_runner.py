"""The compensation feature's physics simulations: runs of the plan and of the compensated
commands on MuJoCo (app.core.simulation) in a worker process, with progress, cancel and the
last good results kept (`SimulationRecord`, in the studio state). Owned by the simulation
session; not a session of its own.
"""

from __future__ import annotations

import dataclasses
import itertools
import logging
import threading
import time
from collections.abc import Callable

import numpy as np

from app.core.motions.trajectory import Trajectory
from app.core.robot.model import RobotModel
from app.core.servo.model import ServoModel
from app.core.simulation.balance_feedback import BalanceGains
from app.core.simulation.experiments import clipped_commands, with_note
from app.core.simulation.on_plan import OnPlan, on_plan_stance
from app.core.simulation.result import SimulationResult
from app.core.simulation.run import UNAIDED, finish_job, simulation_job
from app.core.simulation.servo_law import ServoLaw
from app.core.simulation.worker import SIMULATION_KEY, SimulationJob, build_simulation_problem
from app.jobs import SolverWorker
from app.studio.signals import Signal

log = logging.getLogger(__name__)

WITHOUT, WITH = "without compensation", "with compensation"
SIMULATED = {"sim_without": WITHOUT, "sim_with": WITH}
"""Ghost name -> the simulated run it shows."""
SIMULATE_AGAIN = "press Simulate without / with compensation again"
"""What a crashed simulation asks of the user (the Compensation panel's button)."""


@dataclasses.dataclass(frozen=True)
class Simulation:
    """One Simulate click: what was simulated and what came back."""

    job_id: str
    robot: RobotModel
    trajectory: Trajectory
    job: SimulationJob
    started_s: float
    results: dict[str, SimulationResult] = dataclasses.field(default_factory=dict)
    error: str = ""
    """Why it failed ("cancelled", a blow-up's message, a crashed worker)."""
    waited_s: float | None = 0.0
    """Wall time of the run [s]; None for a run restored from a project that did not keep it."""
    note: str | None = None
    """What was done to the commands before the run (clipped to the joint limits), or None."""
    unaided: dict[str, SimulationResult] = dataclasses.field(default_factory=dict)
    """With the balance feedback, each run (by label) made again without it, for the verdict
    beside ({} without the feedback, and for a run restored from a project)."""


@dataclasses.dataclass(frozen=True, eq=False)
class SimulationRecord:
    """A good simulation as the state keeps it."""

    run: Simulation
    on_plan: dict[str, OnPlan]
    """Ghost name -> its run moved over the floor onto the plan's stance feet
    (app.core.simulation.on_plan), computed once."""
    stale: bool = False
    """The coefficients or servos changed since it ran."""
    origin: str = "run"
    """"run" (it just ended) or "project" (restored)."""

    def drift_m(self) -> dict[str, float]:
        """Per run (its label), its stance foot's largest distance from the plan's."""
        return {label: self.on_plan[ghost].max_drift_m for ghost, label in SIMULATED.items()}


def simulation_record(
    simulation: Simulation, stale: bool = False, origin: str = "run"
) -> SimulationRecord:
    on_plan = {
        ghost: on_plan_stance(simulation.robot, simulation.trajectory, simulation.results[label].q)
        for ghost, label in SIMULATED.items()
    }
    return SimulationRecord(simulation, on_plan, stale, origin)


class SimulationRunner:
    """One worker process ("solver-worker" for simulations), started on first use."""

    def __init__(self, on_progress: Callable[[float], None]) -> None:
        self._on_progress = on_progress
        self._worker: SolverWorker | None = None
        self._ids = itertools.count(1)
        self._lock = threading.Lock()
        self.running: Simulation | None = None
        self.finished: Signal[Simulation] = Signal("simulation_finished")
        """Emitted once per Simulate, when it ended (results, failure or cancel)."""

    def warm_up(self) -> None:
        """Start the worker process now (spawning takes a second), e.g. once torques exist.
        Only an optimisation: if the process cannot start now, Simulate tries again and says."""
        try:
            self._ensure_worker()
        except (OSError, RuntimeError) as error:
            log.warning("could not start the simulation worker in advance: %s", error)

    def _ensure_worker(self) -> SolverWorker:
        if self._worker is None:
            worker = SolverWorker(build_simulation_problem, again=SIMULATE_AGAIN)
            worker.on_progress(lambda _job, _pct, fraction, _unused: self._on_progress(fraction))
            worker.on_done(self._on_done)
            worker.on_failed(lambda job_id, message: self._end(job_id, error=message))
            worker.on_cancelled(lambda job_id: self._end(job_id, error="cancelled"))
            self._worker = worker
        return self._worker

    def start(
        self,
        robot: RobotModel,
        trajectory: Trajectory,
        q_plan_rad: np.ndarray,
        q_cmd_rad: np.ndarray,
        servo: ServoModel,
        law: ServoLaw | None = None,
        balance: BalanceGains | None = None,
    ) -> Simulation:
        """Check the runs here (SimulationInputError at once) and start them in the worker;
        `law` replaces the virtual servos' (servo parts); `balance`: both runs with the
        balance feedback at these gains, and both again without it (`Simulation.unaided`).
        Commands past a joint limit are clipped to it, with a
        note in both runs' notes (`clipped_commands`)."""
        # computed commands: clipped to the limits as a servo clips its goal (as simulate does)
        commands, note = clipped_commands(
            robot, trajectory.t, {WITHOUT: q_plan_rad, WITH: q_cmd_rad}
        )
        job = simulation_job(
            robot, trajectory, commands, servo, law=law, balance=balance, unaided=True
        )
        simulation = Simulation(
            f"simulation-{next(self._ids)}", robot, trajectory, job, time.monotonic(), note=note
        )
        with self._lock:
            self.running = simulation
        self._ensure_worker().submit(simulation.job_id, job, SIMULATION_KEY)
        return simulation

    def cancel(self) -> None:
        if self._worker is not None:
            self._worker.cancel()

    def _on_done(self, job_id: str, runs: object) -> None:
        with self._lock:
            simulation = self.running
        if simulation is None or simulation.job_id != job_id:
            return
        try:
            results = finish_job(simulation.robot, simulation.trajectory, simulation.job, runs)  # type: ignore[arg-type]
            results = with_note(results, simulation.note)
        except Exception as error:  # the runs came back malformed: a bug, reported as failed
            self._end(job_id, error=f"{type(error).__name__}: {error}")
            return
        unaided = {
            label.removesuffix(UNAIDED): run
            for label, run in results.items()
            if label.endswith(UNAIDED)
        }
        main = {label: run for label, run in results.items() if not label.endswith(UNAIDED)}
        self._end(job_id, results=main, unaided=unaided)

    def _end(
        self,
        job_id: str,
        results: dict[str, SimulationResult] | None = None,
        error: str = "",
        unaided: dict[str, SimulationResult] | None = None,
    ) -> None:
        with self._lock:
            simulation = self.running
            if simulation is None or simulation.job_id != job_id:
                return
            self.running = None
        ended = dataclasses.replace(
            simulation,
            results=results or {},
            unaided=unaided or {},
            error=error,
            waited_s=time.monotonic() - simulation.started_s,
        )
        self.finished.emit(ended)

    def close(self) -> None:
        if self._worker is not None:
            self._worker.close()
            self._worker = None
