"""The gait NLP's derivatives assembled from per-kind blocks (SxNlp.block, nlp.py).

A kind of block (the constraints of one knot or interval of a mode) is built and differentiated
once on local symbols (Jacobian, Hessian of λᵀg) and evaluated over its instances with
Function.map; `block_derivatives` gathers the values into IPOPT's sparse constraint Jacobian and
Lagrangian Hessian by a constant matrix, and differentiates the rest (a few constraints, the
cost) as a whole on its own small graph.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Sequence
from typing import Any

import casadi as ca
import numpy as np


class BlockRecorder:
    """What a block builder constrains (SxNlp.block): the same call as SxNlp.constrain."""

    def __init__(self) -> None:
        self.parts: list[tuple[Any, float, float, str]] = []

    def constrain(self, expr: Any, lower: float = 0.0, upper: float = 0.0, tag: str = "") -> None:
        self.parts.append((ca.vec(ca.SX(expr)), lower, upper, tag))


BlockBuilder = Callable[..., None]
"""build(recorder: BlockRecorder, *local_symbols) -> None"""


class BlockKind:
    """One kind of block: its constraint function and, on first use, its derivatives in the
    block's variables, as functions of the concatenated local inputs."""

    def __init__(
        self, name: str, local: list[ca.SX], parts: list[tuple[Any, float, float, str]]
    ) -> None:
        self.name = "block_" + "_".join(re.findall(r"[A-Za-z0-9]+", name))
        self.local = local
        self.sizes = [int(a.shape[0]) for a in local]
        self.offsets = np.concatenate([[0], np.cumsum(self.sizes)[:-1]]).astype(int)
        self.parts = [(int(e.shape[0]), lower, upper, tag) for e, lower, upper, tag in parts]
        self.expr = ca.vertcat(*(e for e, *_ in parts))
        self.n_rows = int(self.expr.shape[0])
        self.function = ca.Function(self.name, local, [self.expr])
        self.variables: tuple[int, ...] | None = None
        self._jacobian: tuple[ca.Function, np.ndarray, np.ndarray] | None = None
        self._hessian: tuple[ca.Function, np.ndarray, np.ndarray] | None = None
        self._given = False

    def classify(self, variable: list[bool], parameter: list[bool]) -> None:
        """Record which arguments are variables; every other must be a parameter, and every
        call of the kind must agree."""
        if not all(v or p for v, p in zip(variable, parameter, strict=True)):
            raise ValueError(f"{self.name}: a block's arguments must be variables or parameters")
        variables = tuple(i for i, v in enumerate(variable) if v)
        if self.variables is None:
            self.variables = variables
        elif self.variables != variables:
            raise ValueError(f"{self.name}: calls differ in which arguments are variables")

    def set_derivatives(
        self,
        jacobian: tuple[ca.Function, np.ndarray, np.ndarray],
        hessian: tuple[ca.Function, np.ndarray, np.ndarray],
    ) -> None:
        """Use these derivative functions (compiled ones, nlp_codegen.py), of the same inputs
        and nonzeros as `jacobian()` and `hessian()` would derive."""
        self._jacobian, self._hessian = jacobian, hessian
        self._given = True

    @property
    def loaded(self) -> bool:
        """Whether the derivatives were given (set_derivatives: compiled, from the cache)
        rather than derived here."""
        return self._given

    def _w(self) -> ca.SX:
        assert self.variables is not None
        return ca.vertcat(*(self.local[i] for i in self.variables))

    def jacobian(self) -> tuple[ca.Function, np.ndarray, np.ndarray]:
        """(inputs -> Jacobian nonzeros, their rows, their columns among the variables)."""
        if self._jacobian is None:
            J = ca.jacobian(self.expr, self._w())
            r, c = (np.array(a, dtype=int) for a in J.sparsity().get_triplet())
            inputs = ca.vertcat(*self.local)
            self._jacobian = (ca.Function(f"{self.name}_jac", [inputs], [J.nz[:]]), r, c)
        return self._jacobian

    def values(self) -> ca.Function:
        """inputs (concatenated) -> the block's constraint values (what `function` gives)."""
        return ca.Function(f"{self.name}_g", [ca.vertcat(*self.local)], [self.expr])

    def hessian(self) -> tuple[ca.Function, np.ndarray, np.ndarray]:
        """([inputs; λ] -> nonzeros of ∇²(λᵀ g), their rows and columns among the variables)."""
        if self._hessian is None:
            lam = ca.SX.sym("lam", self.n_rows)
            H = ca.hessian(ca.dot(lam, self.expr), self._w())[0]
            r, c = (np.array(a, dtype=int) for a in H.sparsity().get_triplet())
            inputs = ca.vertcat(*self.local, lam)
            self._hessian = (ca.Function(f"{self.name}_hess", [inputs], [H.nz[:]]), r, c)
        return self._hessian


class _Triplets:
    """(row, column, value) entries of a sparse MX matrix; duplicates add up."""

    def __init__(self) -> None:
        self.rows: list[np.ndarray] = []
        self.cols: list[np.ndarray] = []
        self.values: list[ca.MX] = []

    def add(self, rows: np.ndarray, cols: np.ndarray, values: ca.MX) -> None:
        self.rows.append(np.asarray(rows, dtype=int).ravel())
        self.cols.append(np.asarray(cols, dtype=int).ravel())
        self.values.append(values)

    def matrix(self, n_rows: int, n_cols: int, *, upper: bool = False) -> ca.MX:
        """The sparse matrix; with `upper`, the upper triangle of a symmetric one (an entry
        below the diagonal has its mirror among the entries too, so it is dropped)."""
        rows = np.concatenate(self.rows) if self.rows else np.zeros(0, dtype=int)
        cols = np.concatenate(self.cols) if self.cols else np.zeros(0, dtype=int)
        keep = rows <= cols if upper else np.ones(rows.size, dtype=bool)
        sparsity, mapping = ca.Sparsity.triplet(
            n_rows, n_cols, rows[keep].tolist(), cols[keep].tolist(), True
        )
        # gather[k, i] = 1 when entry i is nonzero k (kept entries only).
        kept = np.flatnonzero(keep)
        gather = ca.DM(
            ca.Sparsity.triplet(sparsity.nnz(), rows.size, list(mapping), kept.tolist()), 1.0
        )
        values = ca.vertcat(*self.values) if self.values else ca.MX(0, 1)
        return ca.MX(sparsity, ca.mtimes(gather, values))


BlockCall = tuple[BlockKind, tuple[ca.SX, ...], int]
"""(kind, arguments, first row) of one block instance."""


def block_derivatives(
    calls: Sequence[BlockCall],
    cost: Any,
    x: ca.SX,
    p: ca.SX,
    g: ca.SX,
    *,
    exact: bool,
    load: Callable[[BlockKind], bool] | None = None,
) -> tuple[dict[str, ca.Function], ca.Function]:
    """IPOPT's derivative functions, assembled from each block kind's derivatives (taken
    once, on its local symbols, and evaluated over its instances with Function.map) and
    the derivatives of the rest (constraints added with `constrain`, and the cost), taken
    on their own small graph; and nlpsol's problem, (x, p) -> (f, g), g assembled the same
    way from the kinds' values (the block rows) and the rest's. A kind that `load`
    (nlp_codegen.load_compiled) gives compiled derivatives from the codegen cache uses them
    instead of deriving its own.
    Differentiating the whole problem at once costs time in proportion to its size times the
    colours of its sparsity (~20 s at 160 knots); a flat SX function of all the constraints
    (~70 000 instructions at 38 knots) costs nlpsol ~0.1 s of CPU per build to differentiate
    for its own use, and ~7 MB to serialise (nlp_cache.py), where the maps cost next to
    nothing."""
    nx, npar, ng = x.shape[0], p.shape[0], g.shape[0]
    # Where each symbol is in z = [x; p; lam_g] (the derivative functions' inputs).
    z_index = {h: i for i, h in enumerate(_hashes(x) + _hashes(p))}
    n_x_p = nx + npar
    by_kind: dict[int, tuple[BlockKind, list[np.ndarray], list[int]]] = {}
    in_block = np.zeros(ng, dtype=bool)
    for entry, args, row in calls:
        idx = [np.array([z_index[h] for h in _hashes(arg)], dtype=int) for arg in args]
        entry.classify([bool(np.all(i < nx)) for i in idx], [bool(np.all(i >= nx)) for i in idx])
        kind = by_kind.setdefault(id(entry), (entry, [], []))
        kind[1].append(np.concatenate(idx))
        kind[2].append(row)
        in_block[row : row + entry.n_rows] = True
    if load is not None:
        for entry, _, _ in by_kind.values():
            load(entry)
    xm, pm = ca.MX.sym("x", nx), ca.MX.sym("p", npar)
    lam_fm, lam_gm = ca.MX.sym("lam_f"), ca.MX.sym("lam_g", ng)
    z_xp, z = ca.vertcat(xm, pm), ca.vertcat(xm, pm, lam_gm)
    jac, hess, values_g = _Triplets(), _Triplets(), _Triplets()
    for entry, arg_index, rows in by_kind.values():
        n = len(rows)
        index = np.stack(arg_index)  # (instances, local inputs)
        assert entry.variables is not None
        local_cols = np.concatenate(
            [entry.offsets[i] + np.arange(entry.sizes[i]) for i in entry.variables]
        )
        cols = index[:, local_cols]  # x index of each local variable, per instance
        row0 = np.array(rows)[:, None]
        block_rows = (row0 + np.arange(entry.n_rows)).ravel()
        inputs = ca.reshape(z_xp[index.ravel().tolist()], -1, n)
        values_g.add(block_rows, np.zeros_like(block_rows), ca.vec(entry.values().map(n)(inputs)))
        function, r, c = entry.jacobian()
        values = function.map(n)(inputs)
        jac.add((row0 + r).ravel(), cols[:, c].ravel(), ca.vec(values))
        if exact:
            function, r, c = entry.hessian()
            lam_index = n_x_p + row0 + np.arange(entry.n_rows)
            with_lam = ca.reshape(z[np.hstack([index, lam_index]).ravel().tolist()], -1, n)
            values = function.map(n)(with_lam)
            hess.add(cols[:, r].ravel(), cols[:, c].ravel(), ca.vec(values))
    _rest_derivatives(x, p, g, cost, ~in_block, exact, (xm, pm, lam_fm, lam_gm), jac, hess)
    rest_rows = np.flatnonzero(~in_block)
    if rest_rows.size:
        g_rest = ca.Function("rest_values", [x, p], [g[rest_rows.tolist()]])
        values_g.add(rest_rows, np.zeros_like(rest_rows), g_rest(xm, pm))
    g_mx = ca.densify(values_g.matrix(ng, 1))
    f_fn = ca.Function("nlp_f_values", [x, p], [cost])
    oracle = ca.Function("gait_nlp", [xm, pm], [f_fn(xm, pm), g_mx], ["x", "p"], ["f", "g"])
    out: dict[str, ca.Function] = {
        "grad_f": ca.Function(
            "nlp_grad_f",
            [x, p],
            [cost, ca.gradient(cost, x)],
            ["x", "p"],
            ["f", "grad_f_x"],
        ),
        "jac_g": ca.Function(
            "nlp_jac_g",
            [xm, pm],
            [g_mx, jac.matrix(ng, nx)],
            ["x", "p"],
            ["g", "jac_g_x"],
        ),
    }
    if exact:
        out["hess_lag"] = ca.Function(
            "nlp_hess_l",
            [xm, pm, lam_fm, lam_gm],
            [hess.matrix(nx, nx, upper=True)],
            ["x", "p", "lam_f", "lam_g"],
            ["triu_hess_gamma_x_x"],
        )
    return out, oracle


def _rest_derivatives(
    x: ca.SX,
    p: ca.SX,
    g: ca.SX,
    cost: Any,
    rest: np.ndarray,
    exact: bool,
    mx: tuple[ca.MX, ca.MX, ca.MX, ca.MX],
    jac: _Triplets,
    hess: _Triplets,
) -> None:
    """The derivatives of what no block holds (constraint rows `rest`, a boolean mask, and
    the cost): small, differentiated as a whole (SX), called on the MX symbols `mx` (x, p,
    lam_f, lam_g) and added to `jac` and `hess`."""
    xm, pm, lam_fm, lam_gm = mx
    ng = g.shape[0]
    x_index = {h: i for i, h in enumerate(_hashes(x))}
    rest_rows = np.flatnonzero(rest)
    lam_f, lam_g = ca.SX.sym("lam_f"), ca.SX.sym("lam_g", ng)
    g_rest = g[rest_rows.tolist()]
    lagrangian = lam_f * cost + ca.dot(lam_g[rest_rows.tolist()], g_rest)
    for expr, is_hessian in ((g_rest, False), (lagrangian, True)):
        if is_hessian and not exact:
            continue
        symbols = [s for s in ca.symvar(expr) if s.element_hash() in x_index]
        if not symbols:
            continue
        w = ca.vertcat(*symbols)
        cols_rest = np.array([x_index[h] for h in _hashes(w)], dtype=int)
        D = ca.hessian(expr, w)[0] if is_hessian else ca.jacobian(expr, w)
        r, c = (np.array(a, dtype=int) for a in D.sparsity().get_triplet())
        if is_hessian:
            nz = ca.Function("rest_hessian", [x, p, lam_f, lam_g], [D.nz[:]])
            hess.add(cols_rest[r], cols_rest[c], nz(xm, pm, lam_fm, lam_gm))
        else:
            nz = ca.Function("rest_jacobian", [x, p], [D.nz[:]])
            jac.add(rest_rows[r], cols_rest[c], nz(xm, pm))


def _hashes(symbols: ca.SX) -> list[int]:
    """Identity of each element of a vector of SX symbols."""
    return [e.element_hash() for e in symbols.nonzeros()]  # type: ignore[attr-defined]
