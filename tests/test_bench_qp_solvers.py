"""The QP baselines of `biped-studio bench` (app.bench.qp_solvers) solve the very same QP as
the studio and reach the same optimum.

- The KKT certificate is checked on a QP small enough to solve by hand (its minimiser is known
  in closed form), and it rejects a point that is not the minimiser: it can fail.
- On samples of servo_biped's one-leg squats (one foot and both feet down; some with active
  bounds, which the studio leaves to DAQP), the studio's own answer and those of DAQP, ProxQP
  and OSQP on the same matrices are each certified by that check, and agree in objective
  and q̈. No timing is asserted.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from app.bench.qp_solvers import (
    BASELINES,
    compare,
    kkt_certificate,
    objective,
    same_qp,
    solved_by,
    studio_answers,
)
from app.core.dynamics.wbc import WbcParams, make_qp
from app.core.dynamics.wbc_reduced import DAQP_INFINITY, ReducedProblem
from app.core.motions.library import run_motion
from app.core.robot.loading import load_robot


def hand_qp() -> ReducedProblem:
    """min ½|y|² − y₀ − 2 y₁, y₀ ≥ 0 (a bound), y₀ + y₁ ≤ 1 (a row): the minimiser is the
    projection of (1, 2) on the half-plane, (0, 1), with multiplier 1 on the row; the
    objective there is ½ − 2 = −1.5."""
    return ReducedProblem(
        H=np.eye(2),
        f=np.array([-1.0, -2.0]),
        A=np.array([[1.0, 1.0]]),
        lower=np.array([0.0, -DAQP_INFINITY]),
        upper=np.array([DAQP_INFINITY, 1.0]),
        T=np.eye(2),
        t=np.zeros(2),
        beta_columns=np.array([0]),
        JT=np.zeros((0, 2)),
        eta0=np.zeros(0),
    )


def test_the_certificate_accepts_the_hand_minimiser_and_rejects_others():
    problem = hand_qp()
    violation, stationarity = kkt_certificate(problem, np.array([0.0, 1.0]))
    assert violation == 0.0 and stationarity < 1e-12
    # Feasible but not optimal: on the row, away from the minimiser (wrong multiplier sign).
    assert kkt_certificate(problem, np.array([0.5, 0.5]))[1] > 0.1
    # The unconstrained minimiser (1, 2) is stationary but breaks the row by 2.
    assert kkt_certificate(problem, np.array([1.0, 2.0]))[0] == pytest.approx(2.0)


def test_every_baseline_solves_the_hand_qp():
    problem = hand_qp()
    for name, make in BASELINES.items():
        y = make()(problem)
        assert np.allclose(y, [0.0, 1.0], atol=1e-4), name
        assert objective(problem, y) == pytest.approx(-1.5, abs=1e-4), name


@pytest.fixture(scope="module")
def squats():
    robot = load_robot("servo_biped")
    traj = run_motion(robot, "one_leg_squats", dt=0.01).trajectory
    # Every 10th sample, plus a run of contiguous ones for the warm-started solvers.
    keep = np.unique(np.concatenate([np.arange(0, traj.n_samples, 10), np.arange(300, 340)]))
    part = dataclasses.replace(
        traj,
        t=traj.t[: len(keep)],  # the samples' own times are not used; a uniform grid is required
        q=traj.q[keep],
        v=traj.v[keep],
        a=traj.a[keep],
        contacts=traj.contacts[keep],
    )
    qp = make_qp(robot, WbcParams())
    built = same_qp(qp, part, passes=1)
    return qp, part, built.problems


def test_studio_and_baselines_reach_the_same_optimum(squats):
    qp, traj, problems = squats
    sizes = {p.H.shape[0] for p in problems}
    assert sizes == {28, 44}, "one foot and both feet down both sampled"
    answers = {"studio": studio_answers(qp, traj, problems)[0]}
    for name, make in BASELINES.items():
        answers[name] = solved_by(make, problems, passes=1)[0]
    # Some samples have an active bound (β = 0 or a limit): not all are interior.
    daqp_active = [
        np.any(np.isclose(y[: len(p.beta_columns)], 0.0, atol=1e-9))
        for p, y in zip(problems, answers["DAQP"], strict=True)
    ]
    assert any(daqp_active), "no sample with an active constraint: the check would be weak"
    rows = compare(problems, answers)
    for name, row in rows.items():
        assert row["answered"] == len(problems), name
        assert row["max_violation"] < 2e-6, name
        assert row["max_stationarity"] < 2e-6, name
        assert row["max_objective_gap"] < 1e-7, name
        assert row["max_qdd_difference"] < 1e-4, name


def test_the_entry_runs_beside_the_feedforward():
    from app.bench import ENTRIES

    names = list(ENTRIES)
    assert names.index("qp_solvers") == names.index("feedforward") + 1
