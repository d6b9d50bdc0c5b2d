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
"""

from __future__ import annotations

import dataclasses
import time
from typing import Literal

import numpy as np
import osqp
import pinocchio as pin
import scipy.sparse as sp
from proxsuite import proxqp
from scipy.linalg.lapack import dposv

from app.core.dynamics.lqr import B_COM
from app.core.dynamics.wbc_reduced import ReducedProblem, ReducedQp, ReducedSolution, reducible
from app.core.dynamics.wbc_terms import SampleInput, Terms, TermsBatch
from app.core.robot.model import RobotModel

N_EDGES = 4
N_CORNERS = 4
LOOP_FORCE_WEIGHT = 1e-8
TOLERANCE = 1e-6
"""The solver's absolute tolerance (and OSQP's relative one; ProxQP's is 0)."""
MAX_ITERATIONS = 2000
"""The solver's iteration cap. A followable sample converges in 25–250 warm-started iterations;
thousands only happen where the plan cannot be followed. The last iterate is used even
then: after `_exact` its dynamics hold and its forces lie in the pyramids whatever the solver's
status, and the caller certifies each sample itself (q̈ against the plan, torque limits)."""
PROXQP_INFINITY = 1e20
"""ProxQP's stand-in for an infinite bound."""
QpSolver = Literal["reduced", "proxqp", "osqp"]
SOLVERS: tuple[QpSolver, ...] = ("reduced", "proxqp", "osqp")
""""reduced" is the default: the same QP with η, the β of a foot in the air and the base
accelerations substituted out, solved by DAQP (app.core.dynamics.wbc_reduced), with one
pinocchio pass per sample; robots with passive joints or closed loops, and a sample DAQP
cannot solve, take the full QP with ProxQP. "proxqp" and "osqp" solve the full QP (62
variables, 74 rows on servo_biped) as before: ProxQP (dense) at ~0.65× OSQP's time (OSQP
refactorises its sparse KKT matrix whenever A's values change, every sample). Same answers
within the solvers' tolerances (tests/core/test_wbc_solvers.py, test_wbc_reduced.py)."""
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


@dataclasses.dataclass(frozen=True)
class QpWeights:
    """What the QP needs from WbcParams, resolved for one robot."""

    mu: float
    alpha: float
    w_qdd: float
    epsilon: float
    eta_max: float
    a: float
    q_lqr: float
    r_lqr: float
    S: np.ndarray
    """Riccati solution of the CoM LQR, shape (6, 6)."""
    tau_max: np.ndarray
    """|τ| bound per actuated joint [N·m or N], shape (n_actuated,), inf when unbounded."""


@dataclasses.dataclass(frozen=True)
class SampleSolution:
    ok: bool
    status: str
    """The solver's status, or why there is no solution, in words."""
    qdd: np.ndarray
    """Generalised accelerations, shape (nv,)."""
    beta: np.ndarray
    """Pyramid coefficients [N], shape (2 * 4 * 4,): foot, corner, edge."""
    f_loop: np.ndarray
    """Internal force of each loop on its link_a side (link_b gets the opposite), world
    frame [N], shape (3 * n_loops,)."""


def pyramid_edges(mu: float) -> np.ndarray:
    """w_i = n + μ d_i as columns, shape (3, 4): n = world z, d = +x, −x, +y, −y (eq. 11)."""
    return np.array(
        [[mu, -mu, 0.0, 0.0], [0.0, 0.0, mu, -mu], [1.0, 1.0, 1.0, 1.0]],
    )


def _moment_map(W: np.ndarray) -> np.ndarray:
    """r_c × w_i = −[w_i]× r_c: the moments (3, 16) of the 16 β of a foot from its corner
    offsets (4, 3), as a (12, 48) map: row 3c + j (offset of corner c, axis j), column
    16k + 4c + i."""
    moment_map = np.zeros((3 * N_CORNERS, 3 * N_CORNERS * N_EDGES))
    for corner in range(N_CORNERS):
        for i in range(N_EDGES):
            w_i = W[:, i]
            minus_skew = -np.array(
                [[0.0, -w_i[2], w_i[1]], [w_i[2], 0.0, -w_i[0]], [-w_i[1], w_i[0], 0.0]]
            )
            for k in range(3):
                moment_map[
                    3 * corner : 3 * corner + 3, N_CORNERS * N_EDGES * k + N_EDGES * corner + i
                ] = minus_skew[k]
    return moment_map


class WholeBodyQp:
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
                w_qdd=weights.w_qdd,
                alpha=weights.alpha,
                eta_max=weights.eta_max,
                a=weights.a,
                q_lqr=weights.q_lqr,
                S=weights.S,
                tau_max=weights.tau_max,
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

    def _fill_constant(self, A: np.ndarray) -> None:
        r, c = self.rows, self.cols
        A[r["contact"], c["eta"]] = -np.eye(12)
        A[r["beta"], c["beta"]] = np.eye(c["beta"].stop - c["beta"].start)
        A[r["eta"], c["eta"]] = np.eye(12)

    def kinematics(self, q: np.ndarray, v: np.ndarray, qdd_des: np.ndarray) -> Terms:
        """Every configuration-dependent term of one sample. With the reduced QP one pinocchio
        pass (computeAllTerms: M, h, joint Jacobians and the drift accelerations at q̈ = 0);
        for the full QP five, as before (CoM with the plan's q̈, crba, nle, joint Jacobians,
        kinematics at q̈ = 0). Then a handful of batched numpy products for both feet."""
        model, data, nv = self.model, self.data, self.nv
        if self.reduced is not None:
            pin.computeAllTerms(model, data, q, v)
            M, h = data.M.copy(), data.nle.copy()  # overwritten by the next sample
            # Newton on the whole robot: the base's linear rows of M q̈ + h are the net
            # external force m (c̈ − g) in the base frame (free-flyer velocity is LOCAL).
            force_base = M[:3] @ qdd_des + h[:3]
            com_acc = data.oMi[1].rotation @ force_base / self.mass + self.gravity
        else:
            pin.centerOfMass(model, data, q, v, qdd_des)
            com_acc = data.acom[0].copy()
            M = pin.crba(model, data, q).copy()  # data.M is overwritten by the next sample
            h = pin.nonLinearEffects(model, data, q, v).copy()
            pin.computeJointJacobians(model, data, q)
            pin.forwardKinematics(model, data, q, v, self.zero_v)
        pin.updateFramePlacements(model, data)
        left, right = self.foot_ids
        J_feet = np.empty((2, 6, nv))
        J_feet[0] = pin.getFrameJacobian(model, data, left, pin.LOCAL)
        J_feet[1] = pin.getFrameJacobian(model, data, right, pin.LOCAL)
        drift_feet = np.empty(12)
        drift_feet[:6] = pin.getFrameAcceleration(model, data, left, pin.LOCAL).vector
        drift_feet[6:] = pin.getFrameAcceleration(model, data, right, pin.LOCAL).vector
        R = np.empty((2, 3, 3))
        R[0] = data.oMf[left].rotation
        R[1] = data.oMf[right].rotation
        J_world = (R[:, None] @ J_feet.reshape(2, 2, 3, nv)).reshape(2, 6, nv)
        offsets = self.corners_array @ R.transpose(0, 2, 1)  # corners from the foot origin, world
        Phi = (
            (J_world.transpose(0, 2, 1) @ self._wrench_maps(offsets))
            .transpose(1, 0, 2)
            .reshape(nv, 2 * N_CORNERS * N_EDGES)
        )
        if self.loop_ids:
            J_loop, drift_loop = self._loop_terms()
        else:
            J_loop, drift_loop = self._no_loop, self._no_drift
        return Terms(
            M=M,
            h=h,
            Phi=Phi,
            J_feet=J_feet.reshape(12, nv),
            drift_feet=drift_feet,
            J_loop=J_loop,
            drift_loop=drift_loop,
            com_acc=com_acc,
        )

    def kinematics_batch(
        self, q: np.ndarray, v: np.ndarray, qdd_des: np.ndarray
    ) -> tuple[TermsBatch, np.ndarray]:
        """`kinematics` of n samples (reduced QP only): one pinocchio pass per sample, then
        the numpy products for all of them at once. Also the wall time of each sample's
        pinocchio calls [s], shape (n,)."""
        model, data, nv, n = self.model, self.data, self.nv, len(q)
        left, right = self.foot_ids
        M, h = np.empty((n, nv, nv)), np.empty((n, nv))
        J_feet, drift = np.empty((n, 2, 6, nv)), np.empty((n, 12))
        R, R_base = np.empty((n, 2, 3, 3)), np.empty((n, 3, 3))
        seconds = np.empty(n)
        local = pin.LOCAL
        for k in range(n):
            begin = time.perf_counter()
            pin.computeAllTerms(model, data, q[k], v[k])
            pin.updateFramePlacements(model, data)
            M[k], h[k], R_base[k] = data.M, data.nle, data.oMi[1].rotation
            J_feet[k, 0] = pin.getFrameJacobian(model, data, left, local)
            J_feet[k, 1] = pin.getFrameJacobian(model, data, right, local)
            drift[k, :6] = pin.getFrameAcceleration(model, data, left, local).vector
            drift[k, 6:] = pin.getFrameAcceleration(model, data, right, local).vector
            R[k, 0], R[k, 1] = data.oMf[left].rotation, data.oMf[right].rotation
            seconds[k] = time.perf_counter() - begin
        force_base = (M[:, :3] @ qdd_des[:, :, None])[:, :, 0] + h[:, :3]
        com_acc = (R_base @ force_base[:, :, None])[:, :, 0] / self.mass + self.gravity
        J_world = (R[:, :, None] @ J_feet.reshape(n, 2, 2, 3, nv)).reshape(n, 2, 6, nv)
        offsets = self.corners_array @ R.transpose(0, 1, 3, 2)  # (n, 2, 4, 3), world
        G = np.empty((n, 2, 6, N_CORNERS * N_EDGES))
        G[:, :, :3] = self._W_tiled
        G[:, :, 3:] = (offsets.reshape(n, 2, 3 * N_CORNERS) @ self._moment_map).reshape(
            n, 2, 3, N_CORNERS * N_EDGES
        )
        Phi = (
            (J_world.transpose(0, 1, 3, 2) @ G)
            .transpose(0, 2, 1, 3)
            .reshape(n, nv, 2 * N_CORNERS * N_EDGES)
        )
        batch = TermsBatch(M, h, Phi, J_feet.reshape(n, 12, nv), drift, com_acc)
        return batch, seconds

    def terms_at(self, batch: TermsBatch, k: int) -> Terms:
        """Sample k of a batch as the Terms `solve` takes."""
        return Terms(
            M=batch.M[k],
            h=batch.h[k],
            Phi=batch.Phi[k],
            J_feet=batch.J_feet[k],
            drift_feet=batch.drift_feet[k],
            J_loop=self._no_loop,
            drift_loop=self._no_drift,
            com_acc=batch.com_acc[k],
        )

    def _loop_terms(self) -> tuple[np.ndarray, np.ndarray]:
        """J_loop (3 n_loops, nv) and J̇_loop q̇ (3 n_loops,) from the current pinocchio data."""
        model, data = self.model, self.data
        world = pin.LOCAL_WORLD_ALIGNED
        J_loop, drift_loop = [], []
        for a, b in self.loop_ids:
            J_a = pin.getFrameJacobian(model, data, a, world)[:3]
            J_b = pin.getFrameJacobian(model, data, b, world)[:3]
            J_loop.append(J_a - J_b)
            drift_loop.append(
                pin.getFrameClassicalAcceleration(model, data, a, world).linear
                - pin.getFrameClassicalAcceleration(model, data, b, world).linear
            )
        return np.vstack(J_loop), np.concatenate(drift_loop)

    def _wrench_maps(self, offsets: np.ndarray) -> np.ndarray:
        """Wrench at each foot's origin (force; moment, world axes) of its 16 β, (2, 6, 16),
        from the corners' offsets (2, 4, 3).

        Column (c, i) is [w_i; r_c × w_i] with r_c the corner's offset from the foot origin;
        r_c × w_i = −[w_i]× r_c is linear in the offsets, one product with a constant map.
        """
        G = np.empty((2, 6, N_CORNERS * N_EDGES))
        G[:, :3] = self._W_tiled
        G[:, 3:] = (offsets.reshape(2, 3 * N_CORNERS) @ self._moment_map).reshape(
            2, 3, N_CORNERS * N_EDGES
        )
        return G

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


def _as_slice(indices: np.ndarray) -> slice | np.ndarray:
    """A slice for contiguous ascending indices (numpy then returns views), else the indices."""
    if len(indices) and np.array_equal(indices, np.arange(indices[0], indices[0] + len(indices))):
        return slice(int(indices[0]), int(indices[0]) + len(indices))
    return indices
