"""Every point of a sweep counted once (solved + failed + cancelled + pending = total), the
failed ones with a one-line reason, and their place on the Pareto plot; a point that the joints'
torque limit cannot walk fails for that reason, evaluated by the real planner."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from app.core.sweeps.evaluate import PointResult, ProblemCache, evaluate_point, failed_point
from app.core.sweeps.outcomes import failures, outcome_of, tally
from app.core.sweeps.pareto import pareto_mask
from app.core.sweeps.plot_points import plot_points
from app.core.sweeps.sampling import sweep_points
from app.core.sweeps.servo_metrics import not_simulated
from app.core.sweeps.spec import SweepSpec


def spec_of(samples: int, simulate: bool = False, **more) -> SweepSpec:
    data = {
        "sampling": "latin",
        "samples": samples,
        "seed": 3,
        "gait": {"knots": 14},
        "pareto": {"sr": "min", "max_torque_Nm": "min"},
        "parameter": [{"name": "step_length_m", "min": 0.12, "max": 0.28}],
        **more,
    }
    if simulate:
        data["simulate"] = True
    return SweepSpec.from_mapping(data)


def solved(point, sr: float, tau: float, fell: float | None = None) -> PointResult:
    """A solved point's result with the given metrics (and a simulation verdict if `fell`)."""
    result = PointResult(
        point.index, point.values, True, "solved", "", sr, sr, tau, 1.0, 1.0, 5, 0.1, 0.0, "w"
    )
    if fell is not None:
        verdict = "falls at 0.8 s" if fell else "stays up"
        result = dataclasses.replace(
            result, fell=fell, max_torso_error_deg=3.0, sim_status=verdict, sim_s=0.5
        )
    return result


def unsolved(point, status: str, reason: str) -> PointResult:
    nan = float("nan")
    return PointResult(
        point.index, point.values, False, status, reason, nan, nan, nan, nan, nan, 50, 1.0, 0.0,
        "w",
    )  # fmt: skip


def test_each_point_is_solved_failed_cancelled_or_still_to_come():
    spec = spec_of(7, simulate=True)
    p = sweep_points(spec)
    sim_failed = dataclasses.replace(
        solved(p[4], 0.3, 2.0),
        **dataclasses.asdict(not_simulated("not simulated: commands leave the joint limits")),
    )
    results = [
        solved(p[0], 0.2, 3.0, fell=0.0),
        solved(p[1], 0.25, 2.5, fell=1.0),  # fell: a verdict, so solved
        unsolved(p[2], "the settings admit no gait", "the joint torque bound |τ| ≤ 2 N·m"),
        unsolved(p[3], "refused", "swing clearance above the swing height"),
        sim_failed,  # its gait solved, its simulation did not run
        failed_point(p[5], "KilledWorker: the worker died\nthree times"),
    ]
    running = tally(results, spec.n_points, simulate=True)
    assert (running.solved, running.failed, running.cancelled, running.pending) == (2, 4, 0, 1)
    assert running.done + running.pending == spec.n_points
    assert running.fell == 1
    ended = tally(results, spec.n_points, simulate=True, finished=True)  # cancelled with 1 left
    assert (ended.solved, ended.failed, ended.cancelled, ended.pending) == (2, 4, 1, 0)
    assert ended.done == spec.n_points == ended.solved + ended.failed + ended.cancelled
    assert ended.line() == (
        "7 / 7 done: 2 solved (1 fell in simulation), 4 failed, 1 cancelled"
    )  # fmt: skip

    listed = {o.index: o for o in failures(results, simulate=True)}
    assert sorted(listed) == [2, 3, 4, 5]
    assert listed[2].stage == "gait" and "torque bound" in listed[2].reason
    assert listed[3].stage == "refused"
    assert listed[4].line() == "simulation: commands leave the joint limits"
    assert listed[5].stage == "worker" and "\n" not in listed[5].reason  # one line
    # without simulation, the same solved gait is a solved point
    assert not outcome_of(sim_failed, simulate=False).failed


def test_counts_refuse_results_that_do_not_fit_the_sweep():
    spec = spec_of(2)
    p = sweep_points(spec)
    with pytest.raises(ValueError, match="2 results"):
        tally([solved(p[0], 0.2, 3.0), solved(p[0], 0.2, 3.0)], spec.n_points, False)


def test_failed_points_sit_in_a_strip_below_and_the_front_is_the_solved_points_pareto_set():
    spec = spec_of(8, simulate=True)
    p = sweep_points(spec)
    rng = np.random.default_rng(5)
    results = [solved(p[i], *rng.uniform(0.1, 1.0, 2), fell=float(i == 3)) for i in range(5)]
    results += [unsolved(p[5], "no gait", "swing clearance"), failed_point(p[6], "boom")]
    # a simulation that failed on a gait with the best metrics of all: not on the front
    results.append(
        dataclasses.replace(
            solved(p[7], 0.01, 0.01), **dataclasses.asdict(not_simulated("not simulated: x"))
        )
    )
    plotted = plot_points(spec, results)
    assert sorted(plotted.index) == list(range(8))  # every returned point is drawn
    kind = dict(zip(plotted.index, plotted.kind, strict=True))
    assert [i for i in range(8) if kind[i] == "failed"] == [5, 6, 7]
    xy = np.array([[r.sr, r.max_torque_Nm] for r in results[:5]])
    expected = {i for i, on in enumerate(pareto_mask(xy, ["min", "min"])) if on}
    assert {i for i in range(8) if kind[i] == "front"} == expected
    assert kind[3] in ("fell", "front")
    rows = {i: plotted.xy[k] for k, i in enumerate(plotted.index)}
    for i in range(5):
        np.testing.assert_allclose(rows[i], xy[i])  # solved points at their metrics
    strip = [rows[i] for i in (5, 6, 7)]
    assert plotted.strip_y is not None and plotted.strip_y < xy[:, 1].min()
    assert all(row[1] == plotted.strip_y for row in strip)
    xs = sorted(row[0] for row in strip)
    assert xs[0] >= xy[:, 0].min() - 1e-12 and xs[-1] <= xy[:, 0].max() + 1e-12
    assert min(np.diff(xs)) > 0  # apart, to be told apart and clicked


def test_a_torque_limit_the_walk_cannot_keep_fails_the_point_with_that_reason():
    """|τ| ≤ 2 N·m on every joint: the planner finds no gait (IPOPT: locally infeasible), and
    the reason names the torque bound; the same sweep at the robot's own 13 N·m solves, with
    a gait that needs more than 2 N·m somewhere: the bound is what stops it."""
    spec = SweepSpec.from_mapping(
        {
            "sampling": "grid",
            "gait": {"knots": 14},
            "parameter": [{"name": "tau_max_Nm", "min": 2.0, "max": 13.0, "levels": 2}],
        }
    )
    cache = ProblemCache()
    results = [evaluate_point(point, cache) for point in sweep_points(spec)]
    counts = tally(results, spec.n_points, spec.simulate, finished=True)
    assert (counts.solved, counts.failed, counts.cancelled) == (1, 1, 0)
    (failed,) = failures(results, spec.simulate)
    assert results[failed.index].values == (2.0,)
    assert failed.stage == "gait" and "torque" in failed.reason
    (ok,) = [r for r in results if r.solved]
    assert ok.values == (13.0,) and ok.max_torque_Nm > 2.0
