"""One sweep point evaluated: its gait solved (or why not) and its metrics.

`evaluate_point` runs wherever it is called: in this process, or in a Dask worker. The gait
NLP of a structure (robot variant, knots, baseline) takes seconds to build and cannot be
pickled, so each process keeps the NLPs it built in a `ProblemCache` and re-solves them point
after point ("warm" NLPs). By default ("anchor" start) each point's solve starts from the gait
of the sweep's fixed settings on the same NLP, solved once per process and structure: a few
IPOPT iterations instead of hundreds from the initial guess, and still a function of the point
only, not of which worker ran it or what that worker solved before.
"""

from __future__ import annotations

import dataclasses
import math
import os
import socket
import time
from collections import OrderedDict
from collections.abc import Hashable, Sequence
from typing import Any

import numpy as np

from app.core.collocation.planar_model import BASE_DOF
from app.core.collocation.result import GaitResult
from app.core.collocation.settings import GaitSettings
from app.core.sweeps.sampling import SweepPoint
from app.core.sweeps.servo_metrics import not_simulated, simulation_metrics

CACHE_SIZE = 8
"""Built NLPs a process keeps (least recently used dropped first); one is ~50–200 MB."""


@dataclasses.dataclass(frozen=True)
class PointResult:
    """The metrics of one sweep point (NaN where there is no gait)."""

    index: int
    values: tuple[float, ...]
    """The swept parameters' values, in the spec's order."""
    solved: bool
    """Whether the planner found a gait (IPOPT converged)."""
    status: str
    """"solved", or what went wrong in plain words."""
    reason: str
    """For a point without a gait: the constraint it ran into (blame) or why it was refused."""
    sr: float
    """Specific resistance E / (M g d) (eq. 9)."""
    sr_incl_impacts: float
    max_torque_Nm: float
    """Largest |joint torque| at the knots [N·m]."""
    max_joint_speed_radps: float
    """Largest |planar joint speed| at the knots [rad/s]."""
    energy_J: float
    iterations: int
    solve_s: float
    """IPOPT time [s]."""
    build_s: float
    """Time spent building the NLP (and solving its anchor gait) for this point [s]: 0 when
    the worker had them."""
    worker: str
    """host:pid of the process that evaluated the point."""
    fell: float = math.nan
    """Simulation (a sweep with simulate = true; NaN otherwise): 1.0 fell, 0.0 stayed up."""
    fall_time_s: float = math.nan
    max_torso_error_deg: float = math.nan
    """Largest torso roll or pitch error against the plan in the simulation [°]."""
    max_tracking_error_deg: float = math.nan
    """Largest |joint angle − plan| in the simulation [°]."""
    rms_joint_error_deg: float = math.nan
    sim_status: str = ""
    """The simulation's verdict, or why it did not run ("" without simulation)."""
    sim_s: float = 0.0
    """Time of the point's walk, torques and simulation [s]."""
    sim_notes: str = ""
    """The simulation's notes, "; "-joined (e.g. commands clipped to the joint limits)."""
    servo_mass_kg: float = math.nan
    """Total mass of the leg servos [kg] (a sweep with servo parts; NaN otherwise)."""
    servo_cost: float = math.nan
    """Total price of the leg servos (NaN where the servo publishes none)."""
    electrical_energy_J: float = math.nan
    """Electrical energy the leg servos drew over the simulated walk [J]."""
    servo_margin: float = math.nan
    """Smallest peak or RMS margin of the leg servos on the walk's planned points."""

    def metric(self, name: str) -> float:
        return float(getattr(self, name))

    def row(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


class ProblemCache:
    """Built gait NLPs of one process, keyed by structure, least recently used dropped."""

    def __init__(self, size: int = CACHE_SIZE) -> None:
        self._problems: OrderedDict[Hashable, Any] = OrderedDict()
        self._anchors: dict[tuple[Hashable, GaitSettings], GaitResult] = {}
        self._size = size
        self.builds = 0
        """How many NLPs this cache has built (a warm hit builds none)."""

    def get(self, key: tuple[Any, int, bool]) -> tuple[Any, float]:
        """The GaitProblem of (robot variant, knots, baseline) and the seconds spent building it
        now (0.0 when it was cached)."""
        if key in self._problems:
            self._problems.move_to_end(key)
            return self._problems[key], 0.0
        from app.core.collocation.gait_problem import GaitProblem

        start = time.perf_counter()
        variant, knots, baseline = key
        problem = GaitProblem(variant.load(), knots=knots, baseline=baseline)
        self.builds += 1
        self._problems[key] = problem
        while len(self._problems) > self._size:
            old, _ = self._problems.popitem(last=False)
            self._anchors = {k: v for k, v in self._anchors.items() if k[0] != old}
        return problem, time.perf_counter() - start

    def anchor(
        self, key: Hashable, problem: Any, settings: GaitSettings
    ) -> tuple[GaitResult, float]:
        """The gait of `settings` on `problem` (solved cold, once per key and settings) and the
        seconds spent solving it now (0.0 when it was cached)."""
        if (key, settings) in self._anchors:
            return self._anchors[(key, settings)], 0.0
        start = time.perf_counter()
        self._anchors[(key, settings)] = result = problem.solve(settings, cold=True)
        return result, time.perf_counter() - start


def _solve(point: SweepPoint, cache: ProblemCache) -> tuple[GaitResult, float, Any]:
    """The point's gait, the setup time (NLP build, anchor solve) [s] and the GaitProblem."""
    key = (point.robot, *point.settings.structure)
    problem, setup_s = cache.get(key)
    if point.start == "previous":
        return problem.solve(point.settings), setup_s, problem
    if point.start == "anchor" and point.anchor is not None:
        anchor, anchor_s = cache.anchor(key, problem, point.anchor)
        setup_s += anchor_s
        if anchor.converged:
            return problem.solve(point.settings, warm_start=anchor), setup_s, problem
    return problem.solve(point.settings, cold=True), setup_s, problem


def _process_cache() -> ProblemCache:
    """This process's cache: one per worker process, made at its first point."""
    global _CACHE
    if _CACHE is None:
        _CACHE = ProblemCache()
    return _CACHE


_CACHE: ProblemCache | None = None


def evaluate_point(point: SweepPoint, cache: ProblemCache | None = None) -> PointResult:
    """Solve the point's gait on its robot variant and read its metrics. Bad input (settings
    the planner refuses, a robot that does not load) gives an unsolved result with the reason;
    only bugs raise."""
    from app.core.errors import StudioError

    cache = cache if cache is not None else _process_cache()
    worker = f"{socket.gethostname()}:{os.getpid()}"
    try:
        point.settings.validate()
        result, build_s, problem = _solve(point, cache)
    except StudioError as error:
        return _unsolved(point, "refused", str(error), worker)
    out = metrics_of(point, result, build_s, worker)
    if point.simulation is None:
        return out
    if not out.solved:
        sim = not_simulated("not simulated: no gait")
    else:
        sim = simulation_metrics(problem.model, result, point.simulation)
    return dataclasses.replace(out, **dataclasses.asdict(sim))


def evaluate_points(points: Sequence[SweepPoint]) -> list[PointResult]:
    """`evaluate_point` of each point in turn, in this process's cache: one Dask task for a few
    points (app/sweep_engine.py), so that the per-task cost of Dask is paid once for them."""
    return [evaluate_point(point) for point in points]


def metrics_of(point: SweepPoint, result: GaitResult, build_s: float, worker: str) -> PointResult:
    """A PointResult from a solve."""
    if not result.converged:
        reason = result.blame or result.status
        out = _unsolved(point, result.status.split(";")[0], reason, worker)
        return dataclasses.replace(
            out, iterations=result.iterations, solve_s=result.solve_s, build_s=build_s
        )
    speeds = np.abs(result.v[:, BASE_DOF:])
    return PointResult(
        index=point.index,
        values=point.values,
        solved=True,
        status=result.status,
        reason="",
        sr=float(result.sr),
        sr_incl_impacts=float(result.sr_incl_impacts),
        max_torque_Nm=float(result.max_abs_tau_Nm),
        max_joint_speed_radps=float(speeds.max()),
        energy_J=float(result.energy_J),
        iterations=int(result.iterations),
        solve_s=float(result.solve_s),
        build_s=build_s,
        worker=worker,
    )


def _unsolved(point: SweepPoint, status: str, reason: str, worker: str) -> PointResult:
    nan = math.nan
    return PointResult(
        point.index, point.values, False, status, reason, nan, nan, nan, nan, nan, 0, 0.0, 0.0,
        worker,
    )  # fmt: skip


def failed_point(point: SweepPoint, message: str) -> PointResult:
    """The result of a point whose evaluation itself failed (a worker lost too often, a bug)."""
    return _unsolved(point, "failed", message, "")


def prepare_point(point: SweepPoint, cache: ProblemCache | None = None) -> float:
    """Build the NLP of the point's structure and solve its anchor gait here, ahead of the
    points (so the first of them pays only its solve); the seconds it took (0.0 when warm)."""
    cache = cache if cache is not None else _process_cache()
    if point.simulation is not None:  # the simulation's modules, imported once per process
        import app.core.dynamics.wbc
        import app.core.servo.commands
        import app.core.simulation.run
        import app.core.walking.walk  # noqa: F401
    key = (point.robot, *point.settings.structure)
    problem, build_s = cache.get(key)
    if point.start == "anchor" and point.anchor is not None:
        build_s += cache.anchor(key, problem, point.anchor)[1]
    return build_s


def solve_point(point: SweepPoint, cache: ProblemCache | None = None) -> GaitResult:
    """The point's gait itself (the same solve as `evaluate_point`), to load the design into the
    studio; a picklable GaitResult, solved where the NLP is warm."""
    return _solve(point, cache if cache is not None else _process_cache())[0]
