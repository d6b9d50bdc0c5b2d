"""IPOPT's side of the gait NLP: the compiled solver pair (cold, warm), its per-iteration
callback, and the outcome of a solve in the studio's words.

Two IPOPT instances share one set of derivative functions: the *cold* one starts from a guess;
the *warm* one (built on first use, from the cold one's derivatives) starts from a previous
solution with its multipliers (WARM_START_OPTIONS). The iteration callback sees (iteration,
objective, constraint violation) and may return True to stop; the iteration limit uses it too,
so it can change per solve without rebuilding the solver.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Sequence
from typing import Any

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


class IpoptCallback(ca.Callback):
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
    callback: IpoptCallback
    lbg: np.ndarray
    ubg: np.ndarray
    problem: dict[str, Any] | None
    """The SX expressions {"x", "p", "f", "g"}; None for an NLP read from the disk cache
    (nlp_cache.py: GaitProblem.expressions builds them when asked)."""
    options: dict[str, Any]
    derivatives: dict[str, ca.Function] = dataclasses.field(default_factory=dict)
    """IPOPT's derivative functions (grad_f, jac_g, hess_lag), shared by both instances."""
    oracle: dict[str, Any] | ca.Function | None = None
    """What both instances are built on: `problem` itself (SxNlp(blocks=False)), or an MX
    function of (x, p) -> (f, g) assembled from the block kinds' values and the rest's
    (nlp_blocks.block_derivatives)."""
    _warm: ca.Function | None = None

    def warm_solver(self) -> ca.Function:
        """The warm-start instance: same problem and derivatives, IPOPT started at a given
        primal-dual point (WARM_START_OPTIONS). Built on first use."""
        if self._warm is None:
            derivatives = self.derivatives or {
                key: self.solver.get_function(name) for key, name in DERIVATIVES.items()
            }
            oracle = self.problem if self.oracle is None else self.oracle
            assert oracle is not None
            self._warm = ca.nlpsol(
                "gait_warm", "ipopt", oracle, {**self.options, **WARM_START_OPTIONS, **derivatives}
            )
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
