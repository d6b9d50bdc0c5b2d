"""A small SX nonlinear program: named variable and constraint blocks, solved by IPOPT.

Why not casadi's Opti: Opti builds MX graphs (slower derivatives unless expanded) and fixes
variable bounds into the problem. Here every expression is SX, the NLP is built once, and every
bound (joint ranges, |τ| ≤ τ_max, slack ∈ [a, b], swing height …) is given at solve time as
lbx/ubx/lbg/ubg, so a slider change re-solves the same compiled problem. Values that enter
expressions (H, step length, μ, weights) are NLP parameters p.

Blocks. Differentiating the whole SX problem at once (what nlpsol does by itself) costs its
size times the colours of its sparsity: ~20 s of CPU at 160 knots, 4 s at 38. The constraints
repeated at every knot or interval are instead added as *blocks* (`block`): built once per kind
on local symbols, differentiated once there (Jacobian, and the Hessian of λᵀg), and evaluated
over the instances with Function.map; the derivatives are assembled into IPOPT's sparse
Jacobian and Lagrangian Hessian by a constant gather matrix. The rest (a few constraints, the
cost) is small and differentiated as a whole. The constraints, bounds and row order are those
of the inlined problem (`SxNlp(blocks=False)`, kept for the tests that compare the two).

Two IPOPT instances share one set of derivative functions: the *cold* one starts from a guess;
the *warm* one (built on first use, in a fraction of a second, from the cold one's derivatives)
starts from a previous solution *with its multipliers* (warm_start_init_point, a small barrier
parameter): after a slider change it converges in 2–3× fewer iterations to the same optimum.

The iteration callback sees (iteration, objective, constraint violation) from IPOPT's
`iteration_callback` and may return True to stop; the iteration limit uses it too, so it can
change per solve without rebuilding the solver.
"""

from __future__ import annotations

import dataclasses
import re
import time
from collections.abc import Callable, Hashable, Sequence
from typing import Any, Protocol

import casadi as ca
import numpy as np

IterationCallback = Callable[[int, float, float], "bool | None"]
"""(iteration, objective, max constraint violation) -> True to stop the solve."""

IPOPT_WORDS = {
    "Solve_Succeeded": "solved",
    "Solved_To_Acceptable_Level": "solved (to IPOPT's acceptable tolerance)",
    "Infeasible_Problem_Detected": (
        "the settings admit no gait: IPOPT found the constraints locally infeasible "
        "(torque or speed bounds too tight, step too long for the time, slack bounds too narrow…)"
    ),
    "Restoration_Failed": (
        "the solver could not get back to feasible points (restoration failed); the settings "
        "probably admit no gait near the starting guess"
    ),
    "Maximum_Iterations_Exceeded": "not converged: the iteration limit was hit",
    "Maximum_CpuTime_Exceeded": "not converged: the time limit was hit",
    "Maximum_WallTime_Exceeded": "not converged: the time limit was hit",
    "Search_Direction_Becomes_Too_Small": "not converged: the search direction became too small",
    "Diverging_Iterates": "not converged: the iterates diverged (unbounded problem?)",
    "Invalid_Number_Detected": "not converged: the model produced NaN or infinite values",
    "Error_In_Step_Computation": "not converged: IPOPT could not compute a step",
    "Not_Enough_Degrees_Of_Freedom": "the settings over-constrain the gait (too few freedoms)",
    "User_Requested_Stop": "stopped on request",
}
WARM_START_OPTIONS: dict[str, Any] = {
    "ipopt.warm_start_init_point": "yes",
    "ipopt.mu_init": 1e-4,
    "ipopt.mu_strategy": "monotone",  # from a converged point: a fixed small barrier
    "ipopt.warm_start_bound_push": 1e-6,
    "ipopt.warm_start_mult_bound_push": 1e-6,
    "ipopt.warm_start_slack_bound_push": 1e-6,
}
"""IPOPT options of the warm instance: start at the given primal-dual point, barrier 1e-4."""
DERIVATIVES = {"hess_lag": "nlp_hess_l", "jac_g": "nlp_jac_g", "grad_f": "nlp_grad_f"}
"""nlpsol's options for user derivative functions, and the cold solver's names for them."""
CONVERGED = ("Solve_Succeeded", "Solved_To_Acceptable_Level")


class Constrainer(Protocol):
    """What adds constraints: an SxNlp, or a block's recorder (SxNlp.block)."""

    def constrain(
        self, expr: Any, lower: float = 0.0, upper: float = 0.0, tag: str = ""
    ) -> None: ...


class SxNlp:
    """Collects SX variables, constraints and a cost; `compile` makes the IPOPT solver.

    `blocks=False` inlines every block (SxNlp.block) into the problem and lets casadi
    differentiate the whole problem at once, as before blocks existed: the same NLP, built
    slower; kept to check the block derivatives against."""

    def __init__(self, *, blocks: bool = True) -> None:
        self.blocks = blocks
        self._x: list[ca.SX] = []
        self._p: list[ca.SX] = []
        self._g: list[ca.SX] = []
        self.x_blocks: dict[str, list[slice]] = {}
        self.g_blocks: dict[str, list[slice]] = {}
        self.p_index: dict[str, int] = {}
        self.nx = self.ng = 0
        self.cost: Any = 0
        self._lbg: list[np.ndarray] = []
        self._ubg: list[np.ndarray] = []
        self._kinds: dict[Hashable, _BlockKind] = {}
        self._calls: list[tuple[_BlockKind, tuple[ca.SX, ...], int]] = []
        """(kind, arguments, first row) of every block instance, for its derivatives."""

    def variable(self, block: str, n: int) -> ca.SX:
        """n new variables, recorded (in order) under `block` for reading the solution back."""
        slices = self.x_blocks.setdefault(block, [])
        sym = ca.SX.sym(f"{block}{len(slices)}", n)
        self._x.append(sym)
        slices.append(slice(self.nx, self.nx + n))
        self.nx += n
        return sym

    def parameter(self, name: str) -> ca.SX:
        sym = ca.SX.sym(name)
        self.p_index[name] = len(self._p)
        self._p.append(sym)
        return sym

    def constrain(self, expr: Any, lower: float = 0.0, upper: float = 0.0, tag: str = "") -> None:
        """lower ≤ expr ≤ upper; `tag` lets solve-time bounds replace lower/upper."""
        expr = ca.vec(ca.SX(expr))
        n = expr.shape[0]
        self._g.append(expr)
        self._lbg.append(np.full(n, lower, dtype=float))
        self._ubg.append(np.full(n, upper, dtype=float))
        if tag:
            self.g_blocks.setdefault(tag, []).append(slice(self.ng, self.ng + n))
        self.ng += n

    def block(self, kind: Hashable, build: BlockBuilder, *args: ca.SX) -> None:
        """Constraints `build(recorder, *args)` adds, built and differentiated once per `kind`
        on local copies of `args` (each a vector of this NLP's variables or parameters), then
        called here with `args`. Every call of a kind must have the same shapes, and the same
        arguments must be variables (resp. parameters) in each call."""
        if not self.blocks:
            build(self, *args)
            return
        entry = self._kinds.get(kind)
        if entry is None:
            local = [ca.SX.sym(f"arg{i}", a.shape[0]) for i, a in enumerate(args)]
            recorder = BlockRecorder()
            build(recorder, *local)
            entry = _BlockKind(str(kind), local, recorder.parts)
            self._kinds[kind] = entry
        row = self.ng
        values = entry.function(*args)
        start = 0
        for n, lower, upper, tag in entry.parts:
            self.constrain(values[start : start + n], lower, upper, tag)
            start += n
        self._calls.append((entry, tuple(args), row))

    def compile(self, options: dict[str, Any]) -> CompiledNlp:
        x, p, g = ca.vertcat(*self._x), ca.vertcat(*self._p), ca.vertcat(*self._g)
        callback = _Callback(x.shape[0], g.shape[0])
        problem = {"x": x, "p": p, "f": self.cost, "g": g}
        derivatives: dict[str, ca.Function] = {}
        oracle: dict[str, Any] | ca.Function = problem
        if self.blocks:
            exact = options.get("ipopt.hessian_approximation", "exact") == "exact"
            g_fn = ca.Function("nlp_g_values", [x, p], [g])
            derivatives = self._derivatives(x, p, g, g_fn, exact=exact)
            oracle = _oracle(x, p, self.cost, g_fn)
        options = {**options, "iteration_callback": callback, **derivatives}
        solver = ca.nlpsol("gait", "ipopt", oracle, options)
        return CompiledNlp(
            solver=solver,
            callback=callback,
            lbg=np.concatenate(self._lbg),
            ubg=np.concatenate(self._ubg),
            problem=problem,
            options=options,
            derivatives=derivatives,
            oracle=oracle,
        )

    def _derivatives(
        self, x: ca.SX, p: ca.SX, g: ca.SX, g_fn: ca.Function, *, exact: bool
    ) -> dict[str, ca.Function]:
        """IPOPT's derivative functions, assembled from each block kind's derivatives (taken
        once, on its local symbols, and evaluated over its instances with Function.map) and
        the derivatives of the rest (constraints added with `constrain`, and the cost), taken
        on their own small graph. Differentiating the whole problem at once costs time in
        proportion to its size times the colours of its sparsity (~20 s at 160 knots)."""
        nx, npar, ng = x.shape[0], p.shape[0], g.shape[0]
        # Where each symbol is in z = [x; p; lam_g] (the derivative functions' inputs).
        z_index = {h: i for i, h in enumerate(_hashes(x) + _hashes(p))}
        n_x_p = nx + npar
        by_kind: dict[int, tuple[_BlockKind, list[np.ndarray], list[int]]] = {}
        in_block = np.zeros(ng, dtype=bool)
        for entry, args, row in self._calls:
            idx = [np.array([z_index[h] for h in _hashes(arg)], dtype=int) for arg in args]
            entry.classify(
                [bool(np.all(i < nx)) for i in idx], [bool(np.all(i >= nx)) for i in idx]
            )
            kind = by_kind.setdefault(id(entry), (entry, [], []))
            kind[1].append(np.concatenate(idx))
            kind[2].append(row)
            in_block[row : row + entry.n_rows] = True
        xm, pm = ca.MX.sym("x", nx), ca.MX.sym("p", npar)
        lam_fm, lam_gm = ca.MX.sym("lam_f"), ca.MX.sym("lam_g", ng)
        z_xp, z = ca.vertcat(xm, pm), ca.vertcat(xm, pm, lam_gm)
        jac, hess = _Triplets(), _Triplets()
        for entry, arg_index, rows in by_kind.values():
            n = len(rows)
            index = np.stack(arg_index)  # (instances, local inputs)
            assert entry.variables is not None
            local_cols = np.concatenate(
                [entry.offsets[i] + np.arange(entry.sizes[i]) for i in entry.variables]
            )
            cols = index[:, local_cols]  # x index of each local variable, per instance
            row0 = np.array(rows)[:, None]
            function, r, c = entry.jacobian()
            values = function.map(n)(ca.reshape(z_xp[index.ravel().tolist()], -1, n))
            jac.add((row0 + r).ravel(), cols[:, c].ravel(), ca.vec(values))
            if exact:
                function, r, c = entry.hessian()
                lam_index = n_x_p + row0 + np.arange(entry.n_rows)
                with_lam = ca.reshape(z[np.hstack([index, lam_index]).ravel().tolist()], -1, n)
                values = function.map(n)(with_lam)
                hess.add(cols[:, r].ravel(), cols[:, c].ravel(), ca.vec(values))
        # The rest: small, differentiated as a whole (SX), called on the MX symbols.
        x_index = {h: i for i, h in enumerate(_hashes(x))}
        rest_rows = np.flatnonzero(~in_block)
        lam_f, lam_g = ca.SX.sym("lam_f"), ca.SX.sym("lam_g", ng)
        g_rest = g[rest_rows.tolist()]
        lagrangian = lam_f * self.cost + ca.dot(lam_g[rest_rows.tolist()], g_rest)
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
        out: dict[str, ca.Function] = {
            "grad_f": ca.Function(
                "nlp_grad_f",
                [x, p],
                [self.cost, ca.gradient(self.cost, x)],
                ["x", "p"],
                ["f", "grad_f_x"],
            ),
            "jac_g": ca.Function(
                "nlp_jac_g",
                [xm, pm],
                [g_fn(xm, pm), jac.matrix(ng, nx)],
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
        return out


class BlockRecorder:
    """What a block builder constrains (SxNlp.block): the same call as SxNlp.constrain."""

    def __init__(self) -> None:
        self.parts: list[tuple[Any, float, float, str]] = []

    def constrain(self, expr: Any, lower: float = 0.0, upper: float = 0.0, tag: str = "") -> None:
        self.parts.append((ca.vec(ca.SX(expr)), lower, upper, tag))


BlockBuilder = Callable[..., None]
"""build(recorder: BlockRecorder, *local_symbols) -> None"""


class _BlockKind:
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


def _oracle(x: ca.SX, p: ca.SX, cost: Any, g_fn: ca.Function) -> ca.Function:
    """nlpsol's problem as an MX function of (x, p) calling the SX functions of the cost and
    of the constraints (`g_fn`, shared with the Jacobian's function). Given the SX expressions themselves,
    nlpsol spends about 0.5 s of CPU per instance setting up the paper's case (38 knots)
    around the whole expression graph; given this function, 0.25 s for the first instance and
    next to nothing for the warm one, with the same values and derivatives."""
    xm, pm = ca.MX.sym("x", x.shape[0]), ca.MX.sym("p", p.shape[0])
    f_fn = ca.Function("nlp_f_values", [x, p], [cost])
    return ca.Function("gait_nlp", [xm, pm], [f_fn(xm, pm), g_fn(xm, pm)], ["x", "p"], ["f", "g"])


def _hashes(symbols: ca.SX) -> list[int]:
    """Identity of each element of a vector of SX symbols."""
    return [e.element_hash() for e in symbols.nonzeros()]  # type: ignore[attr-defined]


class _Callback(ca.Callback):
    """IPOPT's per-iteration hook: counts, reports and may stop the solve."""

    def __init__(self, nx: int, ng: int) -> None:
        ca.Callback.__init__(self)
        self.nx, self.ng = nx, ng
        self.user: IterationCallback | None = None
        self.max_iter = 10**9
        self.iteration = 0
        self.hit_limit = False
        self.error = ""
        """What the user's callback raised, if it did (the solve then stops)."""
        self.lbg = self.ubg = np.zeros(ng)
        self.construct("gait_iterations", {})

    def get_n_in(self) -> int:
        return ca.nlpsol_n_out()

    def get_n_out(self) -> int:
        return 1

    def get_name_in(self, i: int) -> str:
        return ca.nlpsol_out(i)

    def get_name_out(self, i: int) -> str:
        return "ret"

    def get_sparsity_in(self, i: int) -> ca.Sparsity:
        name = ca.nlpsol_out(i)
        if name == "f":
            return ca.Sparsity.scalar()
        if name in ("x", "lam_x"):
            return ca.Sparsity.dense(self.nx)
        if name in ("g", "lam_g"):
            return ca.Sparsity.dense(self.ng)
        return ca.Sparsity(0, 0)

    def reset(
        self, user: IterationCallback | None, max_iter: int, lbg: np.ndarray, ubg: np.ndarray
    ) -> None:
        self.user, self.max_iter, self.iteration, self.hit_limit = user, max_iter, 0, False
        self.lbg, self.ubg = lbg, ubg
        self.error = ""

    def eval(self, arg: Sequence[ca.DM]) -> list[Any]:
        iteration = self.iteration
        self.iteration += 1
        stop = False
        if self.user is not None:
            g = np.asarray(arg[ca.nlpsol_out().index("g")]).ravel()
            violation = float(
                max(np.max(self.lbg - g, initial=0.0), np.max(g - self.ubg, initial=0.0))
            )
            objective = float(arg[ca.nlpsol_out().index("f")])
            # The caller's code (a GUI, a pipe to another process) must not crash IPOPT: what
            # it raises stops the solve and is reported in the result's status.
            try:
                stop = bool(self.user(iteration, objective, violation))
            except Exception as error:
                self.error = f"{type(error).__name__}: {error}"
                stop = True
        if iteration >= self.max_iter:
            self.hit_limit = True
            stop = True
        return [1 if stop else 0]


@dataclasses.dataclass
class CompiledNlp:
    solver: ca.Function
    callback: _Callback
    lbg: np.ndarray
    ubg: np.ndarray
    problem: dict[str, Any]
    options: dict[str, Any]
    derivatives: dict[str, ca.Function] = dataclasses.field(default_factory=dict)
    """IPOPT's derivative functions (grad_f, jac_g, hess_lag), shared by both instances."""
    oracle: dict[str, Any] | ca.Function | None = None
    """What both instances are built on: `problem` itself (SxNlp(blocks=False)), or an MX
    function of (x, p) -> (f, g) over the same SX functions (_oracle)."""
    _warm: ca.Function | None = None

    def warm_solver(self) -> ca.Function:
        """The warm-start instance: same problem and derivatives, IPOPT started at a given
        primal-dual point (WARM_START_OPTIONS). Built on first use."""
        if self._warm is None:
            derivatives = self.derivatives or {
                key: self.solver.get_function(name) for key, name in DERIVATIVES.items()
            }
            self._warm = ca.nlpsol(
                "gait_warm", "ipopt", self.problem if self.oracle is None else self.oracle,
                {**self.options, **WARM_START_OPTIONS, **derivatives},
            )  # fmt: skip
        return self._warm

    def run(
        self,
        x0: np.ndarray,
        p: np.ndarray,
        lbx: np.ndarray,
        ubx: np.ndarray,
        lbg: np.ndarray,
        ubg: np.ndarray,
        *,
        max_iter: int,
        callback: IterationCallback | None,
        multipliers: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> SolveOutcome:
        """Solve from x0; with `multipliers` (lam_x, lam_g of a previous solution) the warm
        instance starts from that primal-dual point."""
        self.callback.reset(callback, max_iter, lbg, ubg)
        args: dict[str, Any] = {"x0": x0, "p": p, "lbx": lbx, "ubx": ubx, "lbg": lbg, "ubg": ubg}
        solver = self.solver
        if multipliers is not None:
            args["lam_x0"], args["lam_g0"] = multipliers
            solver = self.warm_solver()
        start = time.perf_counter()
        out = solver(**args)
        seconds = time.perf_counter() - start
        stats = solver.stats()
        raw = str(stats.get("return_status", "unknown"))
        words = IPOPT_WORDS.get(raw, f"not converged: IPOPT returned {raw}")
        if raw == "User_Requested_Stop" and self.callback.error:
            words = f"stopped: the iteration callback raised {self.callback.error}"
        elif raw == "User_Requested_Stop" and self.callback.hit_limit:
            raw = "Maximum_Iterations_Exceeded"
            words = IPOPT_WORDS[raw]
        x = np.array(out["x"].full()).ravel()
        g = np.array(out["g"].full()).ravel()
        violation = max(
            np.max(lbg - g, initial=0.0),
            np.max(g - ubg, initial=0.0),
            np.max(lbx - x, initial=0.0),
            np.max(x - ubx, initial=0.0),
        )
        return SolveOutcome(
            raw_status=raw,
            converged=raw in CONVERGED,
            words=words,
            iterations=int(stats.get("iter_count", self.callback.iteration)),
            seconds=seconds,
            x=x,
            lam_g=np.array(out["lam_g"].full()).ravel(),
            lam_x=np.array(out["lam_x"].full()).ravel(),
            g=g,
            objective=float(out["f"]),
            violation=float(violation),
        )


@dataclasses.dataclass(frozen=True)
class SolveOutcome:
    raw_status: str
    converged: bool
    words: str
    iterations: int
    seconds: float
    x: np.ndarray
    lam_g: np.ndarray
    lam_x: np.ndarray
    g: np.ndarray
    """The constraints' values at the returned point."""
    objective: float
    violation: float
