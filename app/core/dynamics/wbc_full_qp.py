"""The full whole-body QP of eqs. 12–18 solved by ProxQP or OSQP (wbc_qp's docstring): A's
configuration-dependent blocks filled, a sample's bounds and linear cost, the solver call warm
from the last sample, the restart after a failure, and the exact fix of the equalities.

FullQpMixin is one part of app.core.dynamics.wbc_qp.WholeBodyQp (state set up by its
__init__; the default "reduced" solver falls back on it where it cannot reduce).
"""

from __future__ import annotations

import time

import numpy as np
import osqp
from proxsuite import proxqp
from scipy.linalg.lapack import dposv

from app.core.dynamics.lqr import B_COM
from app.core.dynamics.wbc_terms import QpWeights, SampleInput, SampleSolution, Terms

TOLERANCE = 1e-6
"""The solver's absolute tolerance (and OSQP's relative one; ProxQP's is 0)."""
MAX_ITERATIONS = 2000
"""The solver's iteration cap. A followable sample converges in 25–250 warm-started iterations;
thousands only happen where the plan cannot be followed. The last iterate is used even
then: after `_exact` its dynamics hold and its forces lie in the pyramids whatever the solver's
status, and the caller certifies each sample itself (q̈ against the plan, torque limits)."""
PROXQP_INFINITY = 1e20
"""ProxQP's stand-in for an infinite bound."""
PROXQP_STATUSES = {
    proxqp.PROXQP_SOLVED: "solved",
    proxqp.PROXQP_MAX_ITER_REACHED: "maximum iterations reached",
    proxqp.PROXQP_PRIMAL_INFEASIBLE: "primal infeasible",
    proxqp.PROXQP_DUAL_INFEASIBLE: "dual infeasible",
    proxqp.PROXQP_SOLVED_CLOSEST_PRIMAL_FEASIBLE: "primal infeasible",
}
FAILED_STATUSES = {
    "primal infeasible": "no accelerations, forces inside the friction pyramids and torques "
    "within their limits satisfy the dynamics (QP infeasible)",
    "dual infeasible": "the QP is unbounded",
    "non convex": "the QP is not convex",
}


class FullQpMixin:
    """The full QP's part of WholeBodyQp."""

    weights: QpWeights
    solver_name: str
    nv: int
    n: int
    m: int
    n_eq: int
    rows: dict[str, slice]
    cols: dict[str, slice]
    A: np.ndarray
    P: np.ndarray
    G_u: np.ndarray
    H_u: np.ndarray
    gravity: np.ndarray
    loop_ids: list[tuple[int, int]]
    nz_rows: np.ndarray
    nz_cols: np.ndarray
    solver: osqp.OSQP
    last_x: np.ndarray | None
    last_solver_s: float
    last_problem: tuple[np.ndarray, np.ndarray, np.ndarray] | None
    last_duals: tuple[np.ndarray, np.ndarray] | None
    _prox: proxqp.dense.QP | None
    _u: slice | np.ndarray
    _limited_v: slice | np.ndarray
    _no_drift: np.ndarray
    _qdd_weight: float
    _GH2: np.ndarray
    _state_bounds: dict[tuple[bool, bool], tuple[np.ndarray, np.ndarray]]
    _state_rows: dict[tuple[bool, bool], np.ndarray]
    _state_mask: dict[tuple[bool, bool], np.ndarray]

    def _fill(self, M, Phi, J_feet, J_loop, out: np.ndarray | None = None) -> np.ndarray:
        """Write the configuration-dependent blocks of A (also used on 0/1 structure)."""
        A = np.zeros((self.m, self.n)) if out is None else out
        r, c, u, lim = self.rows, self.cols, self._u, self._limited_v
        A[r["dyn"], c["qdd"]] = M[u]
        A[r["dyn"], c["beta"]] = -Phi[u]
        A[r["dyn"], c["f"]] = -J_loop[:, u].T
        A[r["loop"], c["qdd"]] = J_loop
        A[r["contact"], c["qdd"]] = J_feet
        A[r["tau"], c["qdd"]] = M[lim]
        A[r["tau"], c["beta"]] = -Phi[lim]
        A[r["tau"], c["f"]] = -J_loop[:, lim].T
        return A

    def solve_full(self, sample: SampleInput) -> SampleSolution:
        """The full QP of eqs. 12–18 (the module docstring) with ProxQP or OSQP."""
        terms, v, contacts, com_error = sample.terms, sample.v, sample.contacts, sample.com_error
        w, r, c = self.weights, self.rows, self.cols
        self._fill(terms.M, terms.Phi, terms.J_feet, terms.J_loop, out=self.A)
        state = (bool(contacts[0]), bool(contacts[1]))
        lower0, upper0 = self._state_bounds[state]
        lower, upper = lower0.copy(), upper0.copy()
        h = terms.h
        lower[r["dyn"]] = upper[r["dyn"]] = -h[self._u]
        if self.loop_ids:
            loop_rhs = -terms.drift_loop - w.alpha * (terms.J_loop @ v)
            lower[r["loop"]] = upper[r["loop"]] = loop_rhs
        else:
            loop_rhs = self._no_drift
        down = self._state_rows[state]  # a foot in the air: free rows and β = 0 (state bounds)
        if len(down):
            slip = -terms.drift_feet - w.alpha * (terms.J_feet @ v)
            rows = r["contact"].start + down
            lower[rows] = upper[rows] = slip[down]
        h_lim = h[self._limited_v]
        lower[r["tau"]] -= h_lim
        upper[r["tau"]] -= h_lim

        # V (eq. 5): ūᵀH_uū + 2 g_uᵀū with ū = G_u β + d, d = g − c̈_des.
        d = self.gravity - terms.com_acc
        p = np.zeros(self.n)
        p[c["qdd"]] = self._qdd_weight * sample.qdd_des
        if com_error.any():
            g_u = w.a * w.q_lqr * com_error[:3] + B_COM.T @ w.S @ com_error
            p[c["beta"]] = 2.0 * self.G_u.T @ (self.H_u @ d + g_u)
        else:  # the feed-forward case, x̄ = 0
            p[c["beta"]] = self._GH2 @ d
        self.last_problem = (p, lower, upper)
        if self.solver_name == "proxqp":
            status, x, raw = self._solve_proxqp(p, lower, upper)
        else:
            status, x, raw = self._solve_osqp(p, lower, upper)
        if status in FAILED_STATUSES or x is None or not np.all(np.isfinite(x)):
            self._restart()
            reason = FAILED_STATUSES.get(status, f"{self.solver_name} returned {raw!r}")
            return SampleSolution(False, reason, *(np.full(0, np.nan),) * 3)
        self.last_x = x
        beta = np.maximum(x[c["beta"]], 0.0) * self._state_mask[state]
        qdd, f_loop = self._exact(terms, loop_rhs, x[c["qdd"]], beta, x[c["f"]])
        return SampleSolution(True, status, qdd, beta, f_loop)

    def _solve_osqp(self, p, lower, upper) -> tuple[str, np.ndarray | None, str]:
        self.solver.update(q=p, l=lower, u=upper, Ax=self.A[self.nz_rows, self.nz_cols])
        begin = time.perf_counter()
        result = self.solver.solve(raise_error=False)
        self.last_solver_s = time.perf_counter() - begin
        status = result.info.status.removesuffix(" inaccurate")
        x = None if result.x is None else np.asarray(result.x)
        return status, x, result.info.status

    def _solve_proxqp(self, p, lower, upper) -> tuple[str, np.ndarray | None, str]:
        """ProxQP (dense) on the same QP: A z = b for the equality rows, l ≤ C z ≤ u for the
        others (a foot's contact rows with l = u when it is down); warm from the last sample."""
        e, A = self.n_eq, self.A
        l_in = np.maximum(lower[e:], -PROXQP_INFINITY)
        u_in = np.minimum(upper[e:], PROXQP_INFINITY)
        begin = time.perf_counter()
        if self._prox is None:
            qp = proxqp.dense.QP(self.n, e, self.m - e)
            qp.settings.eps_abs = TOLERANCE
            qp.settings.eps_rel = 0.0
            qp.settings.max_iter = MAX_ITERATIONS
            qp.settings.verbose = False
            qp.settings.initial_guess = proxqp.InitialGuess.WARM_START_WITH_PREVIOUS_RESULT
            qp.init(self.P, p, A[:e], lower[:e], A[e:], l_in, u_in)
            self._prox = qp
        else:
            self._prox.update(g=p, A=A[:e], b=lower[:e], C=A[e:], l=l_in, u=u_in)
        self._prox.solve()
        self.last_solver_s = time.perf_counter() - begin
        raw = self._prox.results.info.status
        self.last_duals = (np.array(self._prox.results.y), np.array(self._prox.results.z))
        status = PROXQP_STATUSES.get(raw, str(raw))
        return status, np.array(self._prox.results.x), str(raw)

    def _restart(self) -> None:
        """After a failed sample, start the next from the last good solution (OSQP) or cold
        (ProxQP), not from the failed iterate."""
        if self.solver_name == "proxqp":
            self._prox = None
        elif self.last_x is not None:
            self.solver.warm_start(x=self.last_x)

    def reset(self) -> None:
        """Forget the warm start: the next sample is solved cold, as by a fresh WholeBodyQp (so
        a chunk of samples solves the same in any process)."""
        self._prox = None
        self.last_x = None
        if self.solver_name == "osqp":
            self.solver.warm_start(x=np.zeros(self.n), y=np.zeros(self.m))

    def _exact(self, terms: Terms, loop_rhs, qdd, beta, f_loop):
        """Smallest change of q̈ and f_loop that makes eq. 13 and the loop rows hold exactly
        (the solver meets them only to its tolerance); β, already inside the pyramids, is kept."""
        u = self._u
        if not self.loop_ids:  # E = M_u has full row rank: the minimum-norm step
            E = terms.M[u]
            residual = -terms.h[u] + terms.Phi[u] @ beta - E @ qdd
            _, y, info = dposv(E @ E.T, residual)  # E Eᵀ is positive definite
            if info != 0:
                y = np.linalg.lstsq(E @ E.T, residual, rcond=None)[0]
            return qdd + E.T @ y, f_loop
        E_dyn = np.hstack([terms.M[u], -terms.J_loop[:, u].T])
        E_loop = np.hstack([terms.J_loop, np.zeros((len(terms.J_loop), len(f_loop)))])
        E = np.vstack([E_dyn, E_loop])
        target = np.concatenate([-terms.h[u] + terms.Phi[u] @ beta, loop_rhs])
        residual = target - E @ np.concatenate([qdd, f_loop])
        step = np.linalg.lstsq(E, residual, rcond=None)[0]  # a planar loop: a redundant row
        return qdd + step[: self.nv], f_loop + step[self.nv :]
