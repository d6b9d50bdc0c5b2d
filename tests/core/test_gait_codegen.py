"""The codegen cache of the NLP's block derivatives (app/core/collocation/nlp_codegen.py).

A small SxNlp with two block kinds (nonlinear, with a parameter) stands in for the gait NLP:
compiling its kinds costs a second, where the gait's take ~35 s of CPU. Checked: the compiled
derivatives loaded by a later build give the same Jacobian and Lagrangian Hessian as the
derived ones, and as casadi's own differentiation of the whole problem (SxNlp(blocks=False));
the key follows the kind's expression; a cache that is off or broken falls back to deriving.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from app.core.collocation import nlp_codegen
from app.core.collocation.nlp import SxNlp

OPTIONS = {"ipopt.print_level": 0, "ipopt.sb": "yes", "print_time": False}
N = 5


def _toy(scale: float = 1.0, *, blocks: bool = True) -> SxNlp:
    """A chain of N nodes (2 variables each): one block kind per node, one per link."""
    nlp = SxNlp(blocks=blocks)
    k = nlp.parameter("k")
    z = [nlp.variable("z", 2) for _ in range(N)]

    def node(c, zi, k_):  # type: ignore[no-untyped-def]
        c.constrain(ca.sin(zi[0]) * zi[1] ** 2 + scale * k_ * zi[0], -1.0, 1.0, tag="node")

    def link(c, z0, z1, k_):  # type: ignore[no-untyped-def]
        c.constrain(z1 - z0 - k_ * ca.vertcat(ca.cos(z0[1]), z0[0] * z1[1]), tag="link")

    for i in range(N):
        nlp.block("node", node, z[i], k)
    for i in range(N - 1):
        nlp.block("link", link, z[i], z[i + 1], k)
    nlp.cost = sum(ca.sumsqr(zi) for zi in z)
    return nlp


def _derivatives(nlp: SxNlp, x: np.ndarray, p: np.ndarray, lam: np.ndarray) -> tuple:
    compiled = nlp.compile(OPTIONS)
    if compiled.derivatives:
        jac = compiled.derivatives["jac_g"](x, p)[1]
        hess = compiled.derivatives["hess_lag"](x, p, 1.0, lam)
    else:  # inlined: casadi's own derivatives
        jac = compiled.solver.get_function("nlp_jac_g")(x, p)[1]
        hess = compiled.solver.get_function("nlp_hess_l")(x, p, 1.0, lam)
    return np.array(ca.densify(jac)), np.array(ca.triu(ca.densify(hess)))


@pytest.fixture()
def cache(tmp_path, monkeypatch):  # type: ignore[no-untyped-def]
    monkeypatch.setenv(nlp_codegen.CACHE_ENV, str(tmp_path))
    return tmp_path


def test_compiled_derivatives_match_the_derived_ones(cache) -> None:  # type: ignore[no-untyped-def]
    rng = np.random.default_rng(3)
    first = _toy()
    x, p = rng.standard_normal(first.nx), np.array([0.7])
    lam = rng.standard_normal(first.ng)
    derived = _derivatives(first, x, p, lam)
    assert not any(kind.loaded for kind in first._kinds.values())
    thread = nlp_codegen.compile_missing(list(first._kinds.values()), wait=True)
    assert thread is not None
    assert len(list(cache.glob(f"*/{nlp_codegen.LIBRARY}"))) == 2

    again = _toy()
    loaded = _derivatives(again, x, p, lam)
    assert all(kind.loaded for kind in again._kinds.values())
    inlined = _derivatives(_toy(blocks=False), x, p, lam)
    for a, b, c in zip(loaded, derived, inlined, strict=True):
        np.testing.assert_allclose(a, b, atol=1e-12)
        np.testing.assert_allclose(a, c, atol=1e-12)
    # nothing left to compile
    assert nlp_codegen.compile_missing(list(again._kinds.values())) is None


def test_the_key_follows_the_expression(cache) -> None:  # type: ignore[no-untyped-def]
    keys = []
    for scale in (1.0, 1.0, 2.0):
        nlp = _toy(scale)
        nlp.compile(OPTIONS)
        keys.append({name: nlp_codegen.kind_key(kind) for name, kind in nlp._kinds.items()})
    assert keys[0] == keys[1]
    assert keys[2]["node"] != keys[0]["node"]
    assert keys[2]["link"] == keys[0]["link"]


def test_off_or_broken_cache_derives(cache, monkeypatch, caplog) -> None:  # type: ignore[no-untyped-def]
    first = _toy()
    first.compile(OPTIONS)
    nlp_codegen.compile_missing(list(first._kinds.values()), wait=True)
    for library in cache.glob(f"*/{nlp_codegen.LIBRARY}"):
        library.write_bytes(b"not a library")
    broken = _toy()
    broken.compile(OPTIONS)
    assert not any(kind.loaded for kind in broken._kinds.values())
    assert "not loaded" in caplog.text
    monkeypatch.setenv(nlp_codegen.CACHE_ENV, "off")
    assert nlp_codegen.cache_folder() is None
    off = _toy()
    off.compile(OPTIONS)
    assert not any(kind.loaded for kind in off._kinds.values())
