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

Here: the problem's description (SxNlp) and `compile`; nlp_blocks.py the block derivatives;
nlp_ipopt.py the two IPOPT instances, the iteration callback and a solve's outcome.
"""

from __future__ import annotations

from collections.abc import Hashable
from typing import Any, Protocol

import casadi as ca
import numpy as np

from app.core.collocation import nlp_codegen
from app.core.collocation.nlp_blocks import (
    BlockBuilder,
    BlockCall,
    BlockKind,
    BlockRecorder,
    block_derivatives,
)
from app.core.collocation.nlp_ipopt import (
    CONVERGED,
    DERIVATIVES,
    IPOPT_WORDS,
    WARM_START_OPTIONS,
    CompiledNlp,
    IpoptCallback,
    IterationCallback,
    SolveOutcome,
)

__all__ = [
    "CONVERGED",
    "DERIVATIVES",
    "IPOPT_WORDS",
    "WARM_START_OPTIONS",
    "BlockBuilder",
    "BlockRecorder",
    "CompiledNlp",
    "Constrainer",
    "IterationCallback",
    "SolveOutcome",
    "SxNlp",
]


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
        self._kinds: dict[Hashable, BlockKind] = {}
        self._calls: list[BlockCall] = []
        """(kind, arguments, first row) of every block instance, for its derivatives."""
        self.from_cache = False
        """Only the layout, read from the disk cache (SxNlp.restored)."""

    @classmethod
    def restored(
        cls,
        x_blocks: dict[str, list[slice]],
        g_blocks: dict[str, list[slice]],
        p_index: dict[str, int],
        nx: int,
        ng: int,
    ) -> SxNlp:
        """The layout of an NLP read from the disk cache (nlp_cache.py): its variable and row
        blocks and parameters, without expressions (it cannot be compiled again)."""
        nlp = cls()
        nlp.x_blocks, nlp.g_blocks, nlp.p_index = x_blocks, g_blocks, p_index
        nlp.nx, nlp.ng = nx, ng
        nlp.from_cache = True
        return nlp

    @property
    def kinds(self) -> list[BlockKind]:
        """The block kinds (their derivatives classified once `compile` ran)."""
        return list(self._kinds.values())

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
            entry = BlockKind(str(kind), local, recorder.parts)
            self._kinds[kind] = entry
        row = self.ng
        values = entry.function(*args)
        start = 0
        for n, lower, upper, tag in entry.parts:
            self.constrain(values[start : start + n], lower, upper, tag)
            start += n
        self._calls.append((entry, tuple(args), row))

    def compile(self, options: dict[str, Any], *, compile_missing: bool = False) -> CompiledNlp:
        """The IPOPT solver pair. Block kinds whose compiled derivatives are in the codegen
        cache (nlp_codegen.py) use them; with `compile_missing`, the others are compiled into
        it in the background, for the next build."""
        if self.from_cache:
            raise RuntimeError("an NLP read from the disk cache has no expressions to compile")
        x, p, g = ca.vertcat(*self._x), ca.vertcat(*self._p), ca.vertcat(*self._g)
        callback = IpoptCallback(x.shape[0], g.shape[0])
        problem = {"x": x, "p": p, "f": self.cost, "g": g}
        derivatives: dict[str, ca.Function] = {}
        oracle: dict[str, Any] | ca.Function = problem
        if self.blocks:
            exact = options.get("ipopt.hessian_approximation", "exact") == "exact"
            derivatives, oracle = block_derivatives(
                self._calls, self.cost, x, p, g, exact=exact, load=nlp_codegen.load_compiled
            )
            if compile_missing:
                nlp_codegen.compile_missing([k for k in self.kinds if not k.loaded])
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
