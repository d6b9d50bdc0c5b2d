"""The gait NLP built from per-knot blocks (SxNlp.block: each kind differentiated once, its
derivatives mapped over the knots) is the same NLP as the one with every block inlined and
the whole problem differentiated by casadi at once (SxNlp(blocks=False), the construction
before blocks): same constraints, cost, gradient, constraint Jacobian and Lagrangian Hessian
at random points, and the same optimum."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from app.core.collocation import gait_problem, nlp_codegen
from app.core.collocation.gait_problem import GaitProblem
from app.core.collocation.nlp import SxNlp
from app.core.collocation.settings import GaitSettings

KNOTS = 12


class _InlinedProblem(GaitProblem):
    """The same problem with its blocks inlined (casadi differentiates the whole NLP)."""

    def _build(self) -> None:
        self.nlp = SxNlp(blocks=False)
        super()._build()


def _casadi_derivatives(problem: GaitProblem) -> dict[str, ca.Function]:
    """grad_f, jac_g and the Lagrangian's Hessian (lower triangle too) from casadi's AD on the
    whole (inlined) problem."""
    nlp = problem.compiled.problem
    x, p, f, g = nlp["x"], nlp["p"], nlp["f"], nlp["g"]
    lam_f, lam_g = ca.SX.sym("lam_f"), ca.SX.sym("lam_g", g.shape[0])
    hessian = ca.hessian(lam_f * f + ca.dot(lam_g, g), x)[0]
    return {
        "f": ca.Function("f", [x, p], [f]),
        "g": ca.Function("g", [x, p], [g]),
        "grad_f": ca.Function("grad_f", [x, p], [ca.gradient(f, x)]),
        "jac_g": ca.Function("jac_g_x", [x, p], [ca.jacobian(g, x)]),
        "hess": ca.Function("hess_l", [x, p, lam_f, lam_g], [ca.triu(hessian)]),
    }


@pytest.fixture(scope="module", params=[False, True], ids=["symmetric", "baseline"])
def pair(request):
    baseline = request.param
    return GaitProblem(knots=KNOTS, baseline=baseline), _InlinedProblem(
        knots=KNOTS, baseline=baseline
    )


def test_the_inlined_problem_has_no_blocks(pair):
    blocks, inlined = pair
    assert blocks.compiled.derivatives and not inlined.compiled.derivatives


def test_block_derivatives_equal_casadis_on_the_whole_problem(pair):
    blocks, inlined = pair
    assert (blocks.nlp.nx, blocks.nlp.ng) == (inlined.nlp.nx, inlined.nlp.ng)
    assert blocks.nlp.g_blocks == inlined.nlp.g_blocks
    np.testing.assert_array_equal(blocks.compiled.lbg, inlined.compiled.lbg)
    np.testing.assert_array_equal(blocks.compiled.ubg, inlined.compiled.ubg)
    ours = blocks.compiled.derivatives
    reference = _casadi_derivatives(inlined)
    rng = np.random.default_rng(7)
    settings = GaitSettings(knots=KNOTS, baseline=blocks.baseline)
    p = blocks._parameters(settings)
    for _ in range(5):
        x = inlined._guess(settings) + 0.1 * rng.standard_normal(blocks.nlp.nx)
        lam_f, lam_g = rng.uniform(0.5, 2.0), rng.standard_normal(blocks.nlp.ng)
        f, grad = (np.asarray(v.full()).ravel() for v in ours["grad_f"](x, p))
        g, jac = ours["jac_g"](x, p)
        hess = ours["hess_lag"](x, p, lam_f, lam_g)
        np.testing.assert_allclose(f, float(reference["f"](x, p)), rtol=1e-12)
        np.testing.assert_allclose(np.asarray(g.full()).ravel(),
                                   np.asarray(reference["g"](x, p).full()).ravel(),
                                   rtol=1e-10, atol=1e-10)  # fmt: skip
        np.testing.assert_allclose(grad, np.asarray(reference["grad_f"](x, p).full()).ravel(),
                                   rtol=1e-10, atol=1e-10)  # fmt: skip
        np.testing.assert_allclose(np.asarray(ca.densify(jac).full()),
                                   np.asarray(ca.densify(reference["jac_g"](x, p)).full()),
                                   rtol=1e-9, atol=1e-9)  # fmt: skip
        np.testing.assert_allclose(
            np.asarray(ca.densify(hess).full()),
            np.asarray(ca.densify(reference["hess"](x, p, lam_f, lam_g)).full()),
            rtol=1e-9, atol=1e-8,
        )  # fmt: skip


def test_both_constructions_reach_the_same_optimum(pair):
    blocks, inlined = pair
    settings = GaitSettings(knots=KNOTS, baseline=blocks.baseline)
    ours, theirs = blocks.solve(settings, cold=True), inlined.solve(settings, cold=True)
    assert ours.converged and theirs.converged
    assert abs(ours.objective - theirs.objective) <= 1e-6 * max(1.0, abs(theirs.objective))
    np.testing.assert_allclose(
        ours.z, theirs.z, rtol=0, atol=1e-5 * max(1.0, np.abs(theirs.z).max())
    )


def test_building_grows_slower_with_blocks(monkeypatch):
    """Not a clock: the derivative work per knot. The blocks differentiate each kind once, so
    the number of block kinds does not grow with the knots (built: not read from the disk
    cache, nlp_cache.py)."""
    monkeypatch.setenv(nlp_codegen.CACHE_ENV, "off")
    small, large = GaitProblem(knots=8), GaitProblem(knots=gait_problem.COARSE_KNOTS)
    assert len(small.nlp._kinds) == len(large.nlp._kinds) <= 6
