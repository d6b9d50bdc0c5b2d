"""The gait planner's speed-ups (issue 28) keep its answers.

- IPOPT's adaptive barrier strategy reaches the optimum the monotone one reaches, in fewer
  iterations, on the paper's case and on servo_biped (objective and states to tolerance). It
  is measured, not used: on settings that admit no gait it loses the verdict the one line
  needs (app/core/collocation/gait_problem.py, IPOPT_OPTIONS).
- The built-in guess (a per-node leg IK) is computed only when a solve starts from it, once per
  (H, step, swing height).
- The vectorised spline sampling passes through the knots (q, v, u, stance force) and through
  the collocation force at mid-interval, as the splines are defined (sampling.py).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from app.core.collocation import gait_problem
from app.core.collocation.defaults import robot_gait_defaults
from app.core.collocation.gait_problem import GaitProblem
from app.core.collocation.planar_model import PlanarModel
from app.core.collocation.sampling import sample_gait
from app.core.collocation.settings import GaitSettings
from app.core.collocation.transcription import GaitLayout
from app.core.robot.loading import load_robot


def gait_case(name: str) -> tuple[PlanarModel, GaitSettings]:
    """A built-in robot's planar model and gait settings: the paper's for dircon_biped, the
    robot-derived defaults otherwise."""
    planar = PlanarModel(load_robot(name))
    if name == "dircon_biped":
        return planar, GaitSettings()
    return planar, robot_gait_defaults(planar).settings


@pytest.fixture(scope="module", params=["dircon_biped", "servo_biped"])
def both(request):
    """(adaptive result, monotone result) of the same cold solve."""
    planar, settings = gait_case(request.param)
    monotone = GaitProblem(planar, settings.knots, settings.baseline)
    with pytest.MonkeyPatch.context() as patch:
        patch.setitem(gait_problem.IPOPT_OPTIONS, "ipopt.mu_strategy", "adaptive")
        adaptive = GaitProblem(planar, settings.knots, settings.baseline)
    return adaptive.solve(settings, cold=True), monotone.solve(settings, cold=True)


def same_optimum(a, b, z_within: float) -> None:
    """Two converged gait solves at the same optimum: objective to 1e-6 relative, the decision
    vector to `z_within` of its largest entry, the states and torques to 1e-3."""
    assert a.converged and b.converged
    assert abs(a.objective - b.objective) <= 1e-6 * abs(b.objective)
    scale = max(1.0, float(np.abs(b.z).max()))
    assert np.abs(a.z - b.z).max() < z_within * scale
    for name in ("q", "v", "u"):
        np.testing.assert_allclose(getattr(a, name), getattr(b, name), atol=1e-3)


def test_adaptive_barrier_reaches_the_monotone_optimum(both):
    adaptive, monotone = both
    same_optimum(adaptive, monotone, z_within=1e-4)


def test_adaptive_barrier_takes_fewer_iterations(both):
    adaptive, monotone = both
    assert adaptive.iterations < monotone.iterations


@pytest.fixture(scope="module")
def paper():
    problem = GaitProblem()
    return problem, problem.solve(GaitSettings(), cold=True)


def test_the_guess_is_made_only_when_a_solve_starts_from_it(paper, monkeypatch):
    problem, solved = paper
    calls = []
    real = gait_problem.initial_guess
    monkeypatch.setattr(
        gait_problem, "initial_guess", lambda *args: calls.append(args) or real(*args)
    )
    problem._guesses.clear()
    settings = GaitSettings()
    warm = problem.solve(dataclasses.replace(settings, K0=0.9 * settings.K0), warm_start=solved)
    assert warm.converged and warm.warm_iterations_before_cold == 0
    assert calls == []  # a warm start that converges never needs the guess
    for K0 in (settings.K0, 0.9 * settings.K0):  # two cold points, same H, step and swing
        problem.solve(dataclasses.replace(settings, K0=K0), cold=True)
    assert len(calls) == 1
    problem.solve(dataclasses.replace(settings, H_s=1.05 * settings.H_s), cold=True)
    assert len(calls) == 2


def test_samples_pass_through_the_knots_and_the_collocation_forces(paper):
    _, r = paper
    layout = GaitLayout.from_knots(r.structure[0])
    for mode in range(3):
        nodes = np.array(layout.nodes(mode))
        at_knots = sample_gait(r, r.t[nodes], np.full(len(nodes), mode))
        for name, knots in (("q", r.q), ("v", r.v), ("u", r.u), ("stance_force", r.stance_force)):
            np.testing.assert_allclose(getattr(at_knots, name), knots[nodes], atol=1e-12)
        middles = 0.5 * (r.t[nodes[:-1]] + r.t[nodes[1:]])
        at_middles = sample_gait(r, middles, np.full(len(middles), mode))
        np.testing.assert_allclose(at_middles.stance_force, r.mid_force[nodes[:-1]], atol=1e-9)
