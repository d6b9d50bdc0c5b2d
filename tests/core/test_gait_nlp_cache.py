"""The built gait NLP kept on disk (app/core/collocation/nlp_cache.py).

A 12-knot problem stands in for the paper's (the cache does not depend on the knots; saving
is forced without compiled kinds, which would cost ~35 s of compiling). Checked: a problem
read back has the built one's layout and bounds, evaluates to the same cost and constraints as
the NLP's own SX expressions at random points, and solves to the same iterates, cold and warm;
the key follows the robot and the structure; a broken entry or a cache that is off builds.
"""

from __future__ import annotations

import dataclasses

import casadi as ca
import numpy as np
import pytest

from app.core.collocation import nlp_cache, nlp_codegen
from app.core.collocation.gait_problem import GaitProblem
from app.core.collocation.planar_model import PlanarModel
from app.core.collocation.settings import GaitSettings
from app.core.robot.loading import load_robot

KNOTS = 12


@pytest.fixture(scope="module")
def planar() -> PlanarModel:
    return PlanarModel(load_robot("dircon_biped"))


@pytest.fixture()
def cache(tmp_path, monkeypatch):  # type: ignore[no-untyped-def]
    monkeypatch.setenv(nlp_codegen.CACHE_ENV, str(tmp_path))
    return tmp_path


def _saved(planar: PlanarModel) -> GaitProblem:
    """A problem built and saved (kinds not compiled)."""
    built = GaitProblem(planar, KNOTS)
    assert not built.from_cache
    key = nlp_cache.problem_key(planar, KNOTS, False, True)
    assert nlp_cache.save(key, built.nlp, built.knot_swing, built.compiled, require_compiled=False)
    return built


def test_the_nlp_read_back_solves_as_the_built_one(cache, planar) -> None:  # type: ignore[no-untyped-def]
    built = _saved(planar)
    read = GaitProblem(planar, KNOTS)
    assert read.from_cache
    assert read.nlp.x_blocks == built.nlp.x_blocks and read.nlp.g_blocks == built.nlp.g_blocks
    assert read.nlp.p_index == built.nlp.p_index and read.knot_swing == built.knot_swing
    np.testing.assert_array_equal(read.compiled.lbg, built.compiled.lbg)
    np.testing.assert_array_equal(read.compiled.ubg, built.compiled.ubg)
    # the saved problem evaluates as the NLP's expressions (what the bench's baseline solves)
    expressions = read.expressions()
    f_g = ca.Function(
        "f_g", [expressions["x"], expressions["p"]], [expressions["f"], expressions["g"]]
    )
    rng = np.random.default_rng(5)
    for _ in range(3):
        x, p = rng.standard_normal(read.nlp.nx), rng.uniform(0.5, 2.0, len(read.nlp.p_index))
        f_read, g_read = read.compiled.oracle(x, p)  # type: ignore[misc]
        f_sx, g_sx = f_g(x, p)
        np.testing.assert_allclose(float(f_read), float(f_sx), rtol=1e-12)
        np.testing.assert_allclose(np.array(g_read).ravel(), np.array(g_sx).ravel(), atol=1e-9)
    settings = GaitSettings(knots=KNOTS)
    changed = dataclasses.replace(settings, K0=0.8 * settings.K0)
    for problem in (built, read):
        cold = problem.solve(settings, cold=True)
        warm = problem.solve(changed, warm_start=cold)
        assert cold.converged and warm.converged
        problem.results = (cold, warm)  # type: ignore[attr-defined]
    for a, b in zip(built.results, read.results, strict=True):  # type: ignore[attr-defined]
        assert a.iterations == b.iterations
        np.testing.assert_array_equal(a.z, b.z)


def test_the_key_follows_the_robot_and_the_structure(planar) -> None:  # type: ignore[no-untyped-def]
    key = nlp_cache.problem_key(planar, KNOTS, False, True)
    again = PlanarModel(load_robot("dircon_biped"))
    assert nlp_cache.problem_key(again, KNOTS, False, True) == key
    other = PlanarModel(load_robot("servo_biped"))
    variants = {
        nlp_cache.problem_key(other, KNOTS, False, True),
        nlp_cache.problem_key(planar, KNOTS + 1, False, True),
        nlp_cache.problem_key(planar, KNOTS, True, True),
        nlp_cache.problem_key(planar, KNOTS, False, False),
    }
    assert key not in variants and len(variants) == 4


def test_a_broken_entry_or_no_cache_builds(cache, planar, monkeypatch, caplog) -> None:  # type: ignore[no-untyped-def]
    _saved(planar)
    (entry,) = cache.glob("nlp-*")
    (entry / nlp_cache.FUNCTIONS).write_bytes(b"not casadi")
    rebuilt = GaitProblem(planar, KNOTS)
    assert not rebuilt.from_cache and "not loaded" in caplog.text
    monkeypatch.setenv(nlp_codegen.CACHE_ENV, "off")
    key = nlp_cache.problem_key(planar, KNOTS, False, True)
    assert nlp_cache.load(key) is None
    assert not nlp_cache.save(key, rebuilt.nlp, rebuilt.knot_swing, rebuilt.compiled)
