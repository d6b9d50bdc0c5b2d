"""The whole-body QP of the spring-compensation paper (eqs. 12–18), one sample at a time.

Decision variables z = [q̈ (nv), β (2 feet × 4 corners × 4 edges), η (2 × 6), f_loop (3 per
declared loop)]; the QP is min ½zᵀPz + pᵀz subject to l ≤ A z ≤ u (OSQP's form; ProxQP
takes the dynamics and loop rows as A_eq z = b and the others as l ≤ C z ≤ u, a foot's
contact rows with l = u while it is down). The default solver, "reduced", substitutes η, the
β of a foot in the air and the base accelerations out of this same QP
(app.core.dynamics.wbc_reduced) and solves what is left in closed form or with DAQP.

- eq. 13, floating base (and passive joints of closed loops, τ = 0):
  M_u q̈ + h_u = (Φᵀλ)_u + (J_loopᵀ f_loop)_u, u = unactuated rows.
- eq. 14, no slip of a foot in contact: J q̈ + J̇ q̇ = −α J q̇ + η, with J the foot frame's
  6-D Jacobian (LOCAL, so J q̈ + J̇ q̇ is its spatial acceleration). The four corners sit on
  one rigid sole, so this says the same as their twelve point rows in half the rows; η is
  free for a foot in the air.
- closed loops: the two sides of a loop keep together, J_loop q̈ + J̇_loop q̇ = −α J_loop q̇,
  their internal force f_loop is free.
- eq. 15, torque limits on eq. 10's τ = M_a q̈ + h_a − (Φᵀλ)_a − (J_loopᵀ f_loop)_a (B_a = I).
- eqs. 11, 16, 17: λ_c = Σ_i β_ci w_i at each sole corner c, w_i = n + μ d_i, n the ground
  normal (world z), d_i = ±x, ±y (world), β ≥ 0; β = 0 for a foot in the air.
- eq. 18: |η| ≤ η_max.

The cost is eq. 12: V(x̄, ū) + w‖q̈_des − q̈‖² + ε Σβ² + ‖η‖² (+ 1e-8‖f_loop‖², which only
picks one of the equivalent internal forces of a planar loop). V is eq. 5 with the output of
eq. 1 put in, our reading of eqs. 4–5:

    V = ȳᵀQ_p ȳ + v̄ᵀQ_v v̄ + ūᵀRū + 2 x̄ᵀS(A x̄ + B ū),   ȳ = p̄ + a ū,

so that for a = 0 its minimum over ū is the LQR law ū = −K x̄. ū = c̈ − c̈_des is written
through Newton's law on the whole robot, m c̈ = Σλ + m g, which eq. 13 makes exact: V is then
a constant quadratic in β and P never changes; only A, p, l and u change per sample.

This module lays the QP out (columns, rows, the constant cost and bounds) and picks the solver
per sample; its parts live beside it: wbc_kinematics (the per-sample terms from pinocchio),
wbc_full_qp (the full QP with ProxQP or OSQP), wbc_terms (the records), wbc_reduced.
"""

from __future__ import annotations

import time
from typing import Literal

import numpy as np
import osqp
import scipy.sparse as sp
from proxsuite import proxqp

from app.core.dynamics.lqr import B_COM
from app.core.dynamics.wbc_full_qp import MAX_ITERATIONS, TOLERANCE, FullQpMixin
from app.core.dynamics.wbc_kinematics import (
    N_CORNERS,
    N_EDGES,
    QpKinematicsMixin,
    _moment_map,
    pyramid_edges,
)
from app.core.dynamics.wbc_reduced import ReducedProblem, ReducedQp, ReducedSolution, reducible
from app.core.dynamics.wbc_terms import QpWeights, SampleInput, SampleSolution, Terms
from app.core.robot.model import RobotModel

__all__ = [
    "MAX_ITERATIONS",
    "N_CORNERS",
    "N_EDGES",
    "SOLVERS",
    "TOLERANCE",
    "QpSolver",
    "QpWeights",
    "SampleSolution",
    "WholeBodyQp",
    "pyramid_edges",
]

LOOP_FORCE_WEIGHT = 1e-8
QpSolver = Literal["reduced", "proxqp", "osqp"]
SOLVERS: tuple[QpSolver, ...] = ("reduced", "proxqp", "osqp")
""""reduced" is the default: the same QP with η, the β of a foot in the air and the base
accelerations substituted out, solved by DAQP (app.core.dynamics.wbc_reduced), with one
pinocchio pass per sample; robots with passive joints or closed loops, and a sample DAQP
cannot solve, take the full QP with ProxQP. "proxqp" and "osqp" solve the full QP (62
variables, 74 rows on servo_biped) as before: ProxQP (dense) at ~0.65× OSQP's time (OSQP
refactorises its sparse KKT matrix whenever A's values change, every sample). Same answers
within the solvers' tolerances (tests/core/test_wbc_solvers.py, test_wbc_reduced.py)."""


class WholeBodyQp(QpKinematicsMixin, FullQpMixin):
    """The QP's sparsity fixed at construction; `solve` fills values and runs the solver warm."""

    def __init__(self, robot: RobotModel, weights: QpWeights, solver: QpSolver = "reduced") -> None:
        if solver not in SOLVERS:
            raise ValueError(f"unknown QP solver {solver!r}; known: {', '.join(SOLVERS)}")
        # The full QP's solver: "reduced" falls back on ProxQP where it cannot reduce.
        self.solver_name: QpSolver = "proxqp" if solver == "reduced" else solver
        model = robot.model
        self.robot, self.model, self.data, self.weights = robot, model, model.createData(), weights
        self.nv = nv = model.nv
        self.mass = robot.mass_kg
        self.gravity = np.array(model.gravity.linear)
        self.foot_ids = [robot.link_frame_ids[foot.link] for foot in robot.feet]
        self.corners = [np.asarray(foot.sole_corners_m, dtype=float) for foot in robot.feet]
        self.corners_array = np.array(self.corners)  # (2, 4, 3)
        self.loop_ids = [
            (robot.link_frame_ids[loop.link_a], robot.link_frame_ids[loop.link_b])
            for loop in robot.tree.loops
        ]
        self.W = pyramid_edges(weights.mu)
        self.actuated = np.array([joint.idx_v for joint in robot.joints], dtype=int)
        passive = [model.joints[model.getJointId(name)].idx_v for name in robot.passive_joints]
        self.unactuated = np.array(list(range(6)) + passive, dtype=int)
        # Basic slicing (a view) where the indices are contiguous, as without passive joints.
        self._u = _as_slice(self.unactuated)
        self._a = _as_slice(self.actuated)
        self.limited = np.flatnonzero(np.isfinite(weights.tau_max))
        self._limited_v = _as_slice(self.actuated[self.limited])
        self._layout()
        A0 = self._constraint_matrix()
        P = self._constant_cost()
        self._solvers(solver, P, A0)
        self.zero_v = np.zeros(nv)
        self._constant_bounds()
        self._qdd_weight = -2.0 * weights.w_qdd
        self._no_loop, self._no_drift = np.zeros((0, nv)), np.zeros(0)
        self._W_tiled = np.tile(self.W, N_CORNERS)  # (3, 16): corner-major, edge-minor
        self._moment_map = _moment_map(self.W)
        self.last_x: np.ndarray | None = None
        self.last_solver_s = 0.0
        """Wall time of the last sample's solver call alone [s]."""
        self.last_problem: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        """(p, l, u) of the last sample (A is self.A, P self.P)."""
        self.last_duals: tuple[np.ndarray, np.ndarray] | None = None
        """ProxQP's multipliers of the last sample: (equality rows, inequality rows)."""

    def _layout(self) -> None:
        """The columns of z = (q̈, β, η, f_loop) and the rows of the constraints, by name."""
        nv = self.nv
        nb, ne, nf = 2 * N_CORNERS * N_EDGES, 12, 3 * len(self.loop_ids)
        self.cols = {"qdd": slice(0, nv), "beta": slice(nv, nv + nb)}
        self.cols["eta"] = slice(nv + nb, nv + nb + ne)
        self.cols["f"] = slice(nv + nb + ne, nv + nb + ne + nf)
        self.n = nv + nb + ne + nf
        sizes = {
            "dyn": len(self.unactuated),
            "loop": nf,
            "contact": 12,
            "tau": len(self.limited),
            "beta": nb,
            "eta": ne,
        }
        self.rows, start = {}, 0
        for name, size in sizes.items():
            self.rows[name] = slice(start, start + size)
            start += size
        self.m = start
        self.n_eq = self.rows["contact"].start
        """Rows dyn and loop are equalities (ProxQP's A z = b); the rest are l ≤ C z ≤ u."""

    def _constraint_matrix(self) -> sp.csc_matrix:
        """Fill A's constant entries and find its sparsity (`nz_rows`, `nz_cols`); A's
        pattern as a CSC matrix of ones."""
        mask = self._fill(*self._structure())
        # Column-major, so ProxQP's Eigen matrices take A's two row blocks without reordering.
        self.A = np.zeros((self.m, self.n), order="F")
        self._fill_constant(self.A)
        self._fill_constant(mask)
        cols, rows = np.nonzero(mask.T != 0.0)  # column-major = CSC order
        self.nz_rows, self.nz_cols = rows, cols
        return sp.csc_matrix((np.ones(len(rows)), (rows, cols)), shape=(self.m, self.n))

    def _constant_cost(self) -> np.ndarray:
        """The constant Hessian `P` (and the CoM LQR's H_u, G_u in it)."""
        weights, nv, n = self.weights, self.nv, self.n
        nb, ne, nf = (self.cols[c].stop - self.cols[c].start for c in ("beta", "eta", "f"))
        # Constant cost: w‖q̈‖², ε‖β‖² + V's quadratic in β, ‖η‖², tiny ‖f_loop‖².
        r, q, a = weights.r_lqr, weights.q_lqr, weights.a
        self.H_u = (r + a * a * q) * np.eye(3)
        self.G_u = np.tile(self.W, 2 * N_CORNERS) / self.mass  # ū = G_u β + g − c̈_des
        P = np.zeros((n, n))
        P[self.cols["qdd"], self.cols["qdd"]] = 2.0 * weights.w_qdd * np.eye(nv)
        P[self.cols["beta"], self.cols["beta"]] = 2.0 * (
            weights.epsilon * np.eye(nb) + self.G_u.T @ self.H_u @ self.G_u
        )
        P[self.cols["eta"], self.cols["eta"]] = 2.0 * np.eye(ne)
        P[self.cols["f"], self.cols["f"]] = 2.0 * LOOP_FORCE_WEIGHT * np.eye(nf)
        self.P = P
        """The constant Hessian of the cost, full and symmetric, shape (n, n)."""
        return P

    def _solvers(self, solver: QpSolver, P: np.ndarray, A0: sp.csc_matrix) -> None:
        """The reduced QP where it applies (solver "reduced"), OSQP set up (solver "osqp");
        ProxQP is made on the first sample."""
        weights, nv = self.weights, self.nv
        self._prox: proxqp.dense.QP | None = None
        self.reduced: ReducedQp | None = None
        """The reduced QP (solver "reduced" on a robot it applies to), else None."""
        if solver == "reduced" and reducible(nv, self.unactuated, len(self.loop_ids)):
            self.reduced = ReducedQp(
                nv,
                weights,
                P_beta=P[self.cols["beta"], self.cols["beta"]],
                G_u=self.G_u,
                H_u=self.H_u,
                gravity=self.gravity,
                b_com=B_COM,
            )
        self.last_reduced: tuple[ReducedProblem, ReducedSolution] | None = None
        """The reduced QP of the last sample and DAQP's answer (solver "reduced")."""
        self.solver = osqp.OSQP()
        if solver == "osqp":
            self.solver.setup(
                sp.triu(sp.csc_matrix(P)).tocsc(),
                np.zeros(self.n),
                A0,
                np.zeros(self.m),
                np.zeros(self.m),
                verbose=False,
                eps_abs=TOLERANCE,
                eps_rel=TOLERANCE,
                polishing=False,  # `_exact` makes the equalities exact; polishing costs ~20 %
                warm_starting=True,
                max_iter=MAX_ITERATIONS,
            )

    def _constant_bounds(self) -> None:
        """The bounds before a sample's values, per contact state (`_state_bounds`), the
        contact rows that are equalities (`_state_rows`) and the β masks (`_state_mask`)."""
        weights = self.weights
        nb = self.cols["beta"].stop - self.cols["beta"].start
        # The bounds that do not change: |τ| (before h), β ≥ 0, |η| ≤ η_max, free contact rows.
        self._lower0, self._upper0 = np.full(self.m, -np.inf), np.full(self.m, np.inf)
        self._lower0[self.rows["tau"]] = -weights.tau_max[self.limited]
        self._upper0[self.rows["tau"]] = weights.tau_max[self.limited]
        self._lower0[self.rows["beta"]] = 0.0
        self._lower0[self.rows["eta"]], self._upper0[self.rows["eta"]] = (
            -weights.eta_max,
            weights.eta_max,
        )
        self._GH2 = 2.0 * self.G_u.T @ self.H_u
        # Per contact state (left down, right down): the bounds before this sample's values,
        # the contact rows that are equalities, and the β mask (0 for a foot in the air).
        self._state_bounds: dict[tuple[bool, bool], tuple[np.ndarray, np.ndarray]] = {}
        self._state_rows: dict[tuple[bool, bool], np.ndarray] = {}
        self._state_mask: dict[tuple[bool, bool], np.ndarray] = {}
        for state in ((False, False), (True, False), (False, True), (True, True)):
            lower, upper = self._lower0.copy(), self._upper0.copy()
            feet = [foot for foot, down in enumerate(state) if down]
            for foot, down in enumerate(state):
                if not down:
                    start = self.rows["beta"].start + foot * N_CORNERS * N_EDGES
                    upper[start : start + N_CORNERS * N_EDGES] = 0.0
            self._state_bounds[state] = (lower, upper)
            self._state_rows[state] = np.array(
                [6 * foot + i for foot in feet for i in range(6)], dtype=int
            )
            self._state_mask[state] = np.repeat(np.array(state, dtype=float), nb // 2)

    def _structure(self):
        """0/1 matrices with the structural nonzeros of M, Φᵀ, the foot and loop Jacobians."""
        model, nv = self.model, self.nv
        dof_joint = np.empty(nv, dtype=int)
        for jid in range(1, model.njoints):
            joint = model.joints[jid]
            dof_joint[joint.idx_v : joint.idx_v + joint.nv] = jid
        supports = [set(model.supports[jid]) for jid in range(model.njoints)]

        def columns(frame_id: int) -> np.ndarray:
            chain = supports[model.frames[frame_id].parentJoint]
            return np.array([float(dof_joint[i] in chain) for i in range(nv)])

        M = np.array(
            [
                [
                    float(
                        dof_joint[i] in supports[dof_joint[j]]
                        or dof_joint[j] in supports[dof_joint[i]]
                    )
                    for j in range(nv)
                ]
                for i in range(nv)
            ]
        )
        feet = [np.tile(columns(fid), (6, 1)) for fid in self.foot_ids]
        Phi = np.hstack([J.T @ np.ones((6, N_CORNERS * N_EDGES)) for J in feet])
        loops = [np.tile(columns(a) + columns(b), (3, 1)) for a, b in self.loop_ids]
        J_loop = np.vstack(loops) if loops else np.zeros((0, nv))
        return M, Phi, np.vstack(feet), J_loop

    def _fill_constant(self, A: np.ndarray) -> None:
        r, c = self.rows, self.cols
        A[r["contact"], c["eta"]] = -np.eye(12)
        A[r["beta"], c["beta"]] = np.eye(c["beta"].stop - c["beta"].start)
        A[r["eta"], c["eta"]] = np.eye(12)

    def solve(self, sample: SampleInput, *, closed_form: bool = True) -> SampleSolution:
        """The QP of one sample: the reduced one when it applies (in closed form when no
        inequality is active, unless `closed_form` is False, else by DAQP), otherwise the
        full one (ProxQP or OSQP, warm from the last sample)."""
        if self.reduced is not None:
            begin = time.perf_counter()
            closed = self.reduced.unconstrained(sample) if closed_form else None
            if closed is not None:
                self.last_solver_s = time.perf_counter() - begin
                self.last_reduced = None
                return SampleSolution(True, closed.status, closed.qdd, closed.beta, self._no_drift)
            problem = self.reduced.problem(sample)
            begin = time.perf_counter()
            answer = self.reduced.solve(problem)
            self.last_solver_s = time.perf_counter() - begin
            self.last_reduced = (problem, answer)
            if answer.ok:
                return SampleSolution(True, answer.status, answer.qdd, answer.beta, self._no_drift)
            spent = self.last_solver_s
            solution = self.solve_full(sample)
            self.last_solver_s += spent
            return solution
        return self.solve_full(sample)

    def corner_forces(self, beta: np.ndarray) -> np.ndarray:
        """λ at each sole corner, world frame [N], shape (..., 2, 4, 3) (eq. 11), from β of
        shape (..., 32)."""
        return beta.reshape(*beta.shape[:-1], 2, N_CORNERS, N_EDGES) @ self.W.T

    def torques(self, terms: Terms, solution: SampleSolution) -> np.ndarray:
        """τ of eq. 10 (B_a = I) [N·m], shape (n_actuated,)."""
        a = self._a
        tau = terms.M[a] @ solution.qdd + terms.h[a] - terms.Phi[a] @ solution.beta
        if self.loop_ids:
            tau -= terms.J_loop[:, a].T @ solution.f_loop
        return tau


def _as_slice(indices: np.ndarray) -> slice | np.ndarray:
    """A slice for contiguous ascending indices (numpy then returns views), else the indices."""
    if len(indices) and np.array_equal(indices, np.arange(indices[0], indices[0] + len(indices))):
        return slice(int(indices[0]), int(indices[0]) + len(indices))
    return indices
