"""The points of a sweep: a grid, uniform random, or a Latin hypercube over the parameters' ranges.

Latin hypercube (McKay et al. 1979): each parameter's range is cut into n equal strata and each
stratum holds exactly one of the n points, in an independent random order per parameter
(scipy.stats.qmc.LatinHypercube). Random and Latin samples are reproducible from the seed.
"""

from __future__ import annotations

import dataclasses
import itertools
from typing import Any

import numpy as np

from app.core.collocation.settings import GaitSettings
from app.core.sweeps.robot_variants import RobotVariant, robot_parameter
from app.core.sweeps.servo_metrics import SimulationSetup
from app.core.sweeps.spec import SweepSpec


@dataclasses.dataclass(frozen=True)
class SweepPoint:
    """One design to evaluate: picklable (numbers, strings), so it travels to a Dask worker."""

    index: int
    values: tuple[float, ...]
    """The swept parameters' values, in the spec's parameter order."""
    robot: RobotVariant
    settings: GaitSettings
    start: str = "anchor"
    """Where the solve starts: "anchor", "cold" or "previous" (app.core.sweeps.spec.START)."""
    anchor: GaitSettings | None = None
    """The sweep's fixed settings on this point's structure: the gait an "anchor" start
    starts from."""
    simulation: SimulationSetup | None = None
    """The walk and servos to simulate the point's gait on (None: no simulation)."""


def unit_samples(spec: SweepSpec) -> np.ndarray:
    """Points in the unit cube, shape (n_points, n_parameters)."""
    d = len(spec.parameters)
    if spec.sampling == "grid":
        axes = [
            np.linspace(0.0, 1.0, p.levels) if p.levels > 1 else np.array([0.5])
            for p in spec.parameters
        ]
        return np.array(list(itertools.product(*axes)), dtype=float).reshape(-1, d)
    if spec.sampling == "random":
        return np.random.default_rng(spec.seed).random((spec.samples, d))
    from scipy.stats import qmc

    return qmc.LatinHypercube(d=d, seed=np.random.default_rng(spec.seed)).random(spec.samples)


def sample_values(spec: SweepSpec) -> np.ndarray:
    """The parameters' values at every point, shape (n_points, n_parameters); whole-number
    settings (knots) rounded. A degenerate range (min = max) gives its one value."""
    unit = unit_samples(spec)
    lo = np.array([p.minimum for p in spec.parameters])
    hi = np.array([p.maximum for p in spec.parameters])
    values = lo + unit * (hi - lo)
    for j, p in enumerate(spec.parameters):
        if p.choices:  # categorical: the unit range cut into one equal stratum per choice
            n = len(p.choices)
            values[:, j] = np.minimum(np.floor(unit[:, j] * n), n - 1)
        elif p.is_integer:
            values[:, j] = np.round(values[:, j])
    return values


def start_point(spec: SweepSpec, defaults: GaitSettings | None = None) -> SweepPoint:
    """The point every anchored solve of `spec` on its robot as built starts from: the built
    robot with the sweep's base settings, anchored on themselves. Preparing it on a worker
    (`evaluate.prepare_point`) builds the NLP and anchor gait those points use."""
    if defaults is None:
        from app.core.collocation.defaults import default_settings

        defaults = default_settings(spec.variant().load())
    base = spec.base_settings(defaults)
    simulation = None
    if spec.simulate:
        simulation = SimulationSetup.of(
            spec.walk_steps, dict(spec.servo), dict(spec.part), user_records(spec)
        )
    return SweepPoint(-1, (), spec.variant(), base, spec.start, base, simulation)


def sweep_points(spec: SweepSpec, defaults: GaitSettings | None = None) -> list[SweepPoint]:
    """Every point of the sweep, in order, from `defaults` (the robot's planner defaults).

    Settings are not validated here: a point whose combination the planner refuses (e.g.
    swing clearance above the swing height where both are swept) is reported as refused, with
    the reason, by its evaluation. `defaults` None: the planner's defaults for the robot."""
    if defaults is None:
        from app.core.collocation.defaults import default_settings

        defaults = default_settings(spec.variant().load())
    base = spec.base_settings(defaults)
    records = user_records(spec)
    points = []
    for i, row in enumerate(sample_values(spec)):
        gait: dict[str, float | int] = {}
        robot: dict[str, float] = {}
        servo: dict[str, float] = dict(spec.servo)
        part: dict[str, Any] = dict(spec.part)
        for p, value in zip(spec.parameters, row, strict=True):
            if p.kind == "gait":
                gait[p.name] = int(value) if p.is_integer else float(value)
            elif p.kind == "servo":
                servo[p.name] = float(value)
            elif p.kind == "part":
                part[p.name] = p.shown(value) if p.choices else float(value)
            else:
                robot[p.name] = float(value)
                setting = robot_parameter(spec.robot, p.name).gait_setting
                if setting:  # the planner's bound follows the robot's (torque limit)
                    gait[setting] = float(value)
        settings = dataclasses.replace(base, **gait)  # type: ignore[arg-type]
        variant = spec.variant(robot)
        points.append(
            SweepPoint(
                i,
                tuple(float(v) for v in row),
                variant,
                settings,
                spec.start,
                dataclasses.replace(base, knots=settings.knots),
                SimulationSetup.of(spec.walk_steps, servo, part, records)
                if spec.simulate
                else None,
            )
        )
    return points


def user_records(spec: SweepSpec) -> tuple[Any, ...]:
    """The ServoRecords of the sweep's user servo files (checked when the spec was made)."""
    from app.core.servo.user_files import records

    return tuple(r for file in spec.user_servos for r in records(file))
