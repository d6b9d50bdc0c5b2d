"""The whole-body QP of app.core.dynamics.wbc_qp made small: the same optimum, fewer unknowns.

The full QP (wbc_qp's docstring) decides z = [q̈ (nv), β (32), η (12)] under 6 dynamics
rows, 12 contact rows and the bounds. Three of its equations fix some unknowns outright, so
they are substituted, not solved for:

- η: a foot in contact has η = J q̈ + J̇ q̇ + α J q̇ (eq. 14); its ‖η‖² becomes a cost on q̈ and
  |η| ≤ η_max (eq. 18) six inequality rows on q̈. A foot in the air has a free η whose only
  term is ‖η‖²: η = 0, gone.
- β of a foot in the air is 0 (eq. 17): those 16 columns are gone.
- the floating base: the 6 base rows of eq. 13 give its accelerations,
  q̈_b = M_bb⁻¹ (Φ_b β − h_b − M_bj q̈_j) (M_bb, the composite inertia of the whole robot,
  is positive definite), so q̈ = T y + t is affine in y = [β_down, q̈_j].

What is left: min ½ yᵀH y + fᵀy subject to β_down ≥ 0, the torque limits of eq. 15 as rows
on y (τ = M_a q̈ + h_a − Φ_a β is affine in y) and the |η| rows; no equality at all. That is
16 + n_a unknowns on one foot (28 on servo_biped, 37 on Roban S14 instead of 62 and 71) and
n_limited + 6 rows besides the bounds. Eliminating only substitutes equations, so both QPs
have the same (unique: the cost is strictly convex in q̈ and β) minimiser.

DAQP, a dual active-set solver, solves it: on its final active set the answer is exact to
round-off (an interior-point or ADMM answer is exact only to its tolerance), and it needs no
warm start (each sample is solved on its own, so chunks agree wherever they run). The base
rows of eq. 13 hold to round-off by construction.

Only robots whose unactuated coordinates are the floating base alone, without closed loops,
take this path (`reducible`); the others (passive joints, loop forces) keep the full QP.
"""

from __future__ import annotations

import dataclasses

import daqp
import numpy as np
from scipy.linalg.lapack import dposv

from app.core.dynamics.wbc_terms import QpWeights, SampleInput, Terms, TermsBatch

DAQP_INFINITY = 1e30
"""DAQP's stand-in for an infinite bound."""
DAQP_STATUSES = {
    -1: "primal infeasible",
    -2: "cycling",
    -3: "dual infeasible",
    -4: "maximum iterations reached",
    -5: "non convex",
    -6: "overdetermined initial active set",
}
_ROOT_2 = float(np.sqrt(2.0))
PER_FOOT = 16
"""Pyramid coefficients β per foot: 4 sole corners × 4 pyramid edges (wbc_qp's layout)."""


@dataclasses.dataclass(frozen=True)
class ReducedProblem:
    """One sample's reduced QP: min ½yᵀHy + fᵀy, lower ≤ [y[:n_bounds]; A y] ≤ upper, and the
    map back to the full QP's unknowns."""

    H: np.ndarray
    """Hessian, shape (ny, ny), ny = n_beta + n_a."""
    f: np.ndarray
    """Linear cost, shape (ny,)."""
    A: np.ndarray
    """Torque-limit rows, then the |η| rows of the feet down, shape (rows, ny)."""
    lower: np.ndarray
    """Bounds of β_down (the first n_beta entries), then of A's rows."""
    upper: np.ndarray
    T: np.ndarray
    """q̈ = T y + t, shape (nv, ny)."""
    t: np.ndarray
    beta_columns: np.ndarray
    """Which of the 32 β are unknowns (the feet down), shape (n_beta,)."""
    JT: np.ndarray
    """η of the feet down = JT y + eta0, shape (6 n_down, ny)."""
    eta0: np.ndarray


@dataclasses.dataclass(frozen=True)
class ReducedSolution:
    ok: bool
    status: str
    qdd: np.ndarray
    """Generalised accelerations, shape (nv,)."""
    beta: np.ndarray
    """All 32 pyramid coefficients (0 for a foot in the air) [N]."""
    y: np.ndarray
    """The reduced unknowns [β_down, q̈_j], shape (ny,)."""


def reducible(nv: int, unactuated: np.ndarray, n_loops: int) -> bool:
    """Whether the QP of this robot can be reduced: base-only unactuated rows, no loops."""
    return n_loops == 0 and np.array_equal(unactuated, np.arange(6)) and nv > 6


class ReducedQp:
    """The reduced QP of one robot: constants at construction, `problem` and `solve` per sample.

    `P_beta` (32, 32) and `GH2` (32, 3) are the full QP's β block of the Hessian and the map
    from d = g − c̈_des to β's linear cost; `G_u` (3, 32), `H_u` (3, 3) ū = G_u β + d and
    V's Hessian in ū (wbc_qp); `weights` the full QP's (it reads w_qdd, alpha, eta_max, a,
    q_lqr, S and tau_max)."""

    def __init__(
        self,
        nv: int,
        weights: QpWeights,
        *,
        P_beta: np.ndarray,
        G_u: np.ndarray,
        H_u: np.ndarray,
        gravity: np.ndarray,
        b_com: np.ndarray,
    ) -> None:
        self.nv, self.na = nv, nv - 6
        w_qdd = weights.w_qdd
        self.w_qdd, self.alpha, self.eta_max = w_qdd, weights.alpha, weights.eta_max
        self.a, self.q_lqr, self.S, self.b_com = weights.a, weights.q_lqr, weights.S, b_com
        self.limited = np.flatnonzero(np.isfinite(weights.tau_max))
        self.limited_v = 6 + self.limited
        self.tau_max = weights.tau_max[self.limited]
        self.G_u, self.H_u, self.gravity = G_u, H_u, gravity
        self.GH2 = 2.0 * G_u.T @ H_u
        # Per contact state: β columns, foot rows, the Hessian's β block, T's constant part.
        self._states: dict[tuple[bool, bool], tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
        self._T0: dict[tuple[bool, bool], np.ndarray] = {}
        self._lower: dict[tuple[bool, bool], np.ndarray] = {}
        self._upper: dict[tuple[bool, bool], np.ndarray] = {}
        self._diagonal: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self._root_2w = float(np.sqrt(2.0 * w_qdd))
        self._P_inverse: dict[tuple[bool, bool], np.ndarray] = {}
        self._w_eye = {n: w_qdd * np.eye(n) for n in (6, 12)}
        for state in ((False, False), (True, False), (False, True), (True, True)):
            down = [foot for foot, is_down in enumerate(state) if is_down]
            columns = np.array(
                [PER_FOOT * foot + i for foot in down for i in range(PER_FOOT)], dtype=int
            )
            rows = np.array([6 * foot + i for foot in down for i in range(6)], dtype=int)
            self._states[state] = (columns, rows, P_beta[np.ix_(columns, columns)])
            self._P_inverse[state] = np.linalg.inv(P_beta[np.ix_(columns, columns)])
            nb = len(columns)
            T0 = np.zeros((nv, nb + self.na))
            T0[6:, nb:] = np.eye(self.na)
            self._T0[state] = T0
            n_eta = len(rows)
            self._lower[state] = np.concatenate(
                [np.zeros(nb), -self.tau_max, np.full(n_eta, -self.eta_max)]
            )
            self._upper[state] = np.concatenate(
                [np.full(nb, DAQP_INFINITY), self.tau_max, np.full(n_eta, self.eta_max)]
            )
            ny = nb + self.na
            diagonal = np.arange(nb, ny)
            self._diagonal[nb] = (diagonal, diagonal)

    def problem(self, sample: SampleInput) -> ReducedProblem:
        """The reduced QP of one sample (see the module docstring).

        T = [X; 0 I] (X the base rows, 6 × ny), so Tᵀ T = XᵀX + [0 0; 0 I] and every
        product with T touches only its 6 base rows and an identity block."""
        terms, v, qdd_des, contacts = sample.terms, sample.v, sample.qdd_des, sample.contacts
        state = (bool(contacts[0]), bool(contacts[1]))
        columns, rows, P_bb = self._states[state]
        nb, nv = len(columns), self.nv
        M, h = terms.M, terms.h
        Phi_down = terms.Phi[:, columns]
        # q̈_b = M_bb⁻¹ (Φ_b β − M_bj q̈_j − h_b): one Cholesky solve for all right-hand sides.
        rhs = np.empty((6, nb + self.na + 1))
        rhs[:, :nb] = Phi_down[:6]
        rhs[:, nb:-1] = -M[:6, 6:]
        rhs[:, -1] = -h[:6]
        _, solved, info = dposv(M[:6, :6], rhs)
        if info != 0:  # M_bb is positive definite for any real robot; round-off otherwise
            solved = np.linalg.lstsq(M[:6, :6], rhs, rcond=None)[0]
        X, t_b = solved[:, :-1], solved[:, -1]
        J_down = terms.J_feet[rows]
        slip = -terms.drift_feet[rows] - self.alpha * (J_down @ v)
        JT = J_down[:, :6] @ X
        JT[:, nb:] += J_down[:, 6:]
        eta0 = J_down[:, :6] @ t_b - slip
        # w‖q̈ − q̈_des‖² + ‖η‖² = ‖K y − k‖² + w‖q̈_j − q̈_des,j‖² + const.
        K = np.vstack([self._root_2w * X, _ROOT_2 * JT])
        k = np.concatenate([self._root_2w * (qdd_des[:6] - t_b), -_ROOT_2 * eta0])
        H = K.T @ K
        H[:nb, :nb] += P_bb
        H[self._diagonal[nb]] += 2.0 * self.w_qdd
        f = -(K.T @ k)
        f[nb:] -= (2.0 * self.w_qdd) * qdd_des[6:]
        f[:nb] += self._beta_cost(terms, sample.com_error)[columns]
        # τ_lim = M_lim q̈ + h_lim − Φ_lim β = A_tau y + tau0, then η = JT y + eta0.
        lim = self.limited_v
        A = np.empty((len(lim) + len(rows), nb + self.na))
        A_tau = A[: len(lim)]
        np.matmul(M[lim, :6], X, out=A_tau)
        A_tau[:, nb:] += M[lim, 6:]
        A_tau[:, :nb] -= Phi_down[lim]
        A[len(lim) :] = JT
        tau0 = M[lim, :6] @ t_b + h[lim]
        lower, upper = self._lower[state].copy(), self._upper[state].copy()
        lower[nb : nb + len(lim)] -= tau0
        upper[nb : nb + len(lim)] -= tau0
        lower[nb + len(lim) :] -= eta0
        upper[nb + len(lim) :] -= eta0
        T = self._T0[state].copy()
        T[:6] = X
        t = np.zeros(nv)
        t[:6] = t_b
        return ReducedProblem(H, f, A, lower, upper, T, t, columns, JT, eta0)

    def unconstrained(self, sample: SampleInput) -> ReducedSolution | None:
        """The QP's answer in closed form when no inequality is active at it, else None.

        Over x = [q̈, β_down] with only the 6 base rows E x = M_b q̈ − Φ_b β = −h_b, the
        KKT conditions are linear: q̈ = −Q⁻¹(c_q + M_bᵀλ), β = P_ββ⁻¹(Φ_bᵀλ − c_β) and a 6 × 6
        system for λ, with Q = 2w I + 2 JᵀJ (J the feet down) inverted by Woodbury through
        w I + J Jᵀ and P_ββ⁻¹ fixed per contact state. If that x has β ≥ 0, torques and η
        within their bounds, it meets the full QP's KKT conditions with zero multipliers on
        every inequality: it is the QP's (unique) minimiser."""
        terms, v, qdd_des, contacts = sample.terms, sample.v, sample.qdd_des, sample.contacts
        state = (bool(contacts[0]), bool(contacts[1]))
        columns, rows, _ = self._states[state]
        P_inverse = self._P_inverse[state]
        M, h, w = terms.M, terms.h, self.w_qdd
        Phi_down = terms.Phi[:, columns]
        J = terms.J_feet[rows]
        slip = -terms.drift_feet[rows] - self.alpha * (J @ v)
        # B = [M_bᵀ, c_q], c_q = −2w q̈_des − 2 Jᵀ slip; Q⁻¹B = (B − Jᵀ(wI + JJᵀ)⁻¹ J B) / 2w.
        B = np.empty((self.nv, 7))
        B[:, :6] = M[:6].T
        B[:, 6] = (-2.0 * w) * qdd_des - 2.0 * (J.T @ slip)
        if len(rows):
            JB = J @ B
            _, inner, info = dposv(J @ J.T + self._w_eye[len(rows)], JB)
            if info != 0:
                return None
            QB = (B - J.T @ inner) * (0.5 / w)
        else:
            QB = B * (0.5 / w)
        c_beta = self._beta_cost(terms, sample.com_error)[columns]
        Phi_b = Phi_down[:6]
        W = Phi_b @ P_inverse  # Φ_b P_ββ⁻¹, shape (6, nb)
        schur = M[:6] @ QB[:, :6] + W @ Phi_b.T
        rhs = h[:6] - M[:6] @ QB[:, 6] + W @ c_beta
        _, lam, info = dposv(schur, rhs)
        if info != 0:
            return None
        beta_down = W.T @ lam - P_inverse @ c_beta
        if beta_down.min(initial=0.0) < 0.0:
            return None
        qdd = -QB[:, 6] - QB[:, :6] @ lam
        lim = self.limited_v
        if len(lim):
            tau = M[lim] @ qdd + h[lim] - Phi_down[lim] @ beta_down
            if np.any(np.abs(tau) > self.tau_max):
                return None
        if len(rows) and np.abs(J @ qdd - slip).max() > self.eta_max:
            return None
        beta = np.zeros(2 * PER_FOOT)
        beta[columns] = beta_down
        return ReducedSolution(True, "solved", qdd, beta, np.concatenate([beta_down, qdd[6:]]))

    def unconstrained_batch(
        self,
        batch: TermsBatch,
        v: np.ndarray,
        qdd_des: np.ndarray,
        state: tuple[bool, bool],
        com_error: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """`unconstrained` for n samples of one contact state at once (stacked numpy
        products, so the per-call overhead is paid once): q̈ (n, nv), β (n, 32) and whether
        the closed form is the answer (n,) (else the sample needs DAQP). Inputs are stacked
        per sample: v, qdd_des (n, nv), com_error (n, 6)."""
        columns, rows, _ = self._states[state]
        P_inverse = self._P_inverse[state]
        M, h, w, n = batch.M, batch.h, self.w_qdd, len(batch.M)
        Phi_down = batch.Phi[:, :, columns]
        J = batch.J_feet[:, rows]
        JT = J.transpose(0, 2, 1)
        slip = -batch.drift_feet[:, rows] - self.alpha * (J @ v[:, :, None])[:, :, 0]
        B = np.empty((n, self.nv, 7))
        B[:, :, :6] = M[:, :6].transpose(0, 2, 1)
        B[:, :, 6] = (-2.0 * w) * qdd_des - 2.0 * (JT @ slip[:, :, None])[:, :, 0]
        if len(rows):
            inner = np.linalg.solve(J @ JT + self._w_eye[len(rows)], J @ B)
            QB = (B - JT @ inner) * (0.5 / w)
        else:
            QB = B * (0.5 / w)
        d = self.gravity - batch.com_acc
        g_u = self.a * self.q_lqr * com_error[:, :3] + com_error @ (self.b_com.T @ self.S).T
        c_beta = (2.0 * (d @ self.H_u.T + g_u) @ self.G_u)[:, columns]
        Phi_b = Phi_down[:, :6]
        W = Phi_b @ P_inverse
        schur = M[:, :6] @ QB[:, :, :6] + W @ Phi_b.transpose(0, 2, 1)
        rhs = h[:, :6, None] - M[:, :6] @ QB[:, :, 6:] + W @ c_beta[:, :, None]
        lam = np.linalg.solve(schur, rhs)
        beta_down = (W.transpose(0, 2, 1) @ lam)[:, :, 0] - c_beta @ P_inverse.T
        qdd = -QB[:, :, 6] - (QB[:, :, :6] @ lam)[:, :, 0]
        ok = beta_down.min(axis=1, initial=0.0) >= 0.0
        lim = self.limited_v
        if len(lim):
            tau = (
                (M[:, lim] @ qdd[:, :, None])[:, :, 0]
                + h[:, lim]
                - (Phi_down[:, lim] @ beta_down[:, :, None])[:, :, 0]
            )
            ok &= np.all(np.abs(tau) <= self.tau_max, axis=1)
        if len(rows):
            eta = (J @ qdd[:, :, None])[:, :, 0] - slip
            ok &= np.abs(eta).max(axis=1) <= self.eta_max
        ok &= np.all(np.isfinite(qdd), axis=1) & np.all(np.isfinite(beta_down), axis=1)
        beta = np.zeros((n, 2 * PER_FOOT))
        beta[:, columns] = beta_down
        return qdd, beta, ok

    def _beta_cost(self, terms: Terms, com_error: np.ndarray) -> np.ndarray:
        """β's linear cost from V (eq. 5): 2 G_uᵀ(H_u d + g_u), d = g − c̈_des, shape (32,)."""
        d = self.gravity - terms.com_acc
        if com_error.any():
            g_u = self.a * self.q_lqr * com_error[:3] + self.b_com.T @ self.S @ com_error
            return 2.0 * self.G_u.T @ (self.H_u @ d + g_u)
        return self.GH2 @ d  # the feed-forward case, x̄ = 0

    def solve(self, problem: ReducedProblem) -> ReducedSolution:
        """DAQP on the reduced QP, cold (the answer of a sample depends on that sample only)."""
        y, _fval, flag, _info = daqp.solve(
            problem.H, problem.f, problem.A, problem.upper, problem.lower
        )
        y = np.asarray(y)
        beta = np.zeros(2 * PER_FOOT)
        if flag < 0 or not np.all(np.isfinite(y)):
            status = DAQP_STATUSES.get(int(flag), f"daqp returned exit flag {flag}")
            return ReducedSolution(False, status, np.full(self.nv, np.nan), beta, y)
        nb = len(problem.beta_columns)
        beta[problem.beta_columns] = np.maximum(y[:nb], 0.0)
        return ReducedSolution(True, "solved", problem.T @ y + problem.t, beta, y)
