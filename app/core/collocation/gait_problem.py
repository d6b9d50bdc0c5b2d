"""GaitProblem: the paper's three-mode symmetric gait NLP (eq. 7), built once, solved many times.

Decision variables: per node q, v, a (planar), u (joint torques), λ (stance force); per
interval γ (velocity correction) and λ̄ (collocation force); per touch-down the impulse Λ; the
foothold slack0 (symmetric) or the middle foothold x1 (baseline); the mode durations (baseline).

Constraints (see transcription.py for the collocation and stance rows):
- knots: M a + h = B u + J_sᵀ λ; φ = 0, J_s v = 0, J_s a + J̇_s v = 0; friction cone
  |f_x| ≤ μ (f_z heel + f_z toe), f_z ≥ 0; swing foot sole points 0 ≤ z ≤ swing height, and
  ≥ swing_clearance_m at mid-swing (our addition: without it the optimum shuffles); Table 1
  joint ranges, |q̇| ≤ qd_max, |u| ≤ τ_max;
- intervals: Hermite–Simpson collocation with γ and λ̄ (λ̄ in the friction cone too);
- touch-downs (virtual knots, eq. 4 with K_O = I): q_post = q_pre,
  M(q_pre)(v_post − v_pre) = J_land(q_pre)ᵀ Λ, Λ in the friction cone, and the lifting foot
  leaves the ground (its sole points' vertical speed ≥ 0);
- footholds: left sole centre at x0 = 0 in mode0, x2 = advance d in mode2, right at x1 in mode1;
  symmetric: x1 = (0.5 + slack0)(x0 + x2), a ≤ slack0 ≤ b (eq. 5);
- symmetric (eq. 6): LSP and RSP last H/2 each; joint states exchanged between the legs at the
  two touch-downs; final state = initial state with x advanced by d. With identical legs and
  both soles flat at a touch-down, the exact exchange makes the two steps mirror images, so
  slack0 = 0 at every solution: eq. 5 then only matters through a ≤ 0 ≤ b;
- baseline ("original DIRCON", section 5.3): no slack, no exchange, free mode durations summing
  to H (mode0, mode2 in [0.05, 0.5]·H, RSP in [0.25, 0.75]·H); periodicity is kept so that the
  gait repeats and its SR is comparable.

Cost: w·(‖(pitch, joints) at start‖² + ‖… at end‖²) (light posture terms toward the upright
standing pose) + K0 Σ_modes h Σ_k ‖u_k‖² + K1 slack0² + K2 Σ_k (‖q_k − q_k−1‖² + ‖v_k − v_k−1‖²
+ ‖u_k − u_k−1‖²) within each mode; the baseline drops the K1 and K2 terms.
"""

from __future__ import annotations

import dataclasses
import functools
import time
from collections.abc import Callable
from typing import Any

import casadi as ca
import numpy as np

from app.core.collocation.blame import Scales, hardest_constraint
from app.core.collocation.guess import initial_guess
from app.core.collocation.mesh_interpolation import interpolate_point
from app.core.collocation.nlp import (
    CompiledNlp,
    Constrainer,
    IterationCallback,
    SolveOutcome,
    SxNlp,
)
from app.core.collocation.planar_model import BASE_DOF, PlanarModel
from app.core.collocation.readout import read_result
from app.core.collocation.result import GaitResult
from app.core.collocation.settings import GaitSettings, GaitSettingsError
from app.core.collocation.transcription import (
    STANCE,
    GaitLayout,
    foot_rows,
    hermite_simpson,
    other,
    stance_rows,
    swing_z_rows,
)
from app.core.robot.model import RobotModel

POSTURE_WEIGHT = 0.05
"""Weight of the light initial/final posture terms (eq. 7's l_0, l_f)."""
IPOPT_OPTIONS: dict[str, Any] = {
    "ipopt.print_level": 0,
    "print_time": False,
    "ipopt.sb": "yes",
    "ipopt.linear_solver": "mumps",
    # MUMPS's own row/column scaling of the KKT matrix: off. On the paper's case it took IPOPT
    # 81 iterations with it and 47 without (same optimum); the other robots are unchanged.
    "ipopt.mumps_scaling": 0,
    "ipopt.mumps_permuting_scaling": 0,
    # MUMPS's threshold pivoting: 1e-10 instead of IPOPT's 1e-6 (raised at most to 1e-6 when
    # IPOPT asks for more accuracy, instead of 0.1): fewer delayed pivots, less fill. The same
    # iterates to 1e-11 on the paper's case, servo_biped and Roban S14, 10–25 % less CPU per
    # iteration (most near an optimum: the warm re-solves). A pivot tolerance of 0 changes
    # the inertia IPOPT sees and takes more iterations (docs/speed.md, "The gait planner").
    "ipopt.mumps_pivtol": 1e-10,
    "ipopt.mumps_pivtolmax": 1e-6,
    # The first barrier parameter: 0.5 instead of 0.1. From the built-in guess IPOPT spends
    # its first ~35 iterations at the first barrier parameter getting feasible with short
    # steps; a larger one keeps the iterates further inside their bounds and gets there in
    # fewer (46 → 34 on the paper's case, 31 → 27 on servo_biped, 62 → 45 on Roban S14, the
    # same optima to 1e-9; tests/core/test_gait_speed.py). Warm starts set their own (1e-4).
    "ipopt.mu_init": 0.5,
    "ipopt.tol": 1e-6,
    "ipopt.constr_viol_tol": 1e-6,
    "ipopt.acceptable_tol": 1e-4,
    "ipopt.acceptable_iter": 10,
    "ipopt.max_iter": 100000,  # the per-solve limit is GaitSettings.max_iter, via the callback
    # Monotone barrier updates. The adaptive strategy takes 25 iterations instead of 46 on the
    # paper's case (23 vs 31 on servo_biped, 33 vs 63 on Roban S14) to the same optima
    # (tests/core/test_gait_speed.py), but on settings that admit no gait (|τ| ≤ 0.1 N·m) it
    # runs to the iteration limit at a point where the torques are off their bound, so the
    # one line blames the clearance and periodicity instead of the torque bound; monotone
    # ends in "Infeasible_Problem_Detected" with the torques at the bound (test_cli.py).
    "ipopt.mu_strategy": "monotone",
}
WARM_ITERATIONS_BEFORE_FALLBACK = 40
"""Iterations a warm start (from the previous solution, with its multipliers when it has them)
gets before the solve restarts cold from the built-in guess with the rest of max_iter
(measured: 5–15 iterations after one slider step on the built-ins and Roban S14; a cold solve
takes 25–50). A warm start that has not converged by then is stalled, not slow: before this
restart the K0 6.5 → 2 re-solve on servo_biped spent 1000 iterations (~200 s) on one point."""
FINAL_WARM_STATUSES = ("User_Requested_Stop", "Infeasible_Problem_Detected")
"""A warm start ending so is not restarted: stopped on request, or IPOPT converged to a point
of locally least infeasibility (tau_max 0.1 N·m: "the settings admit no gait" in 36 iterations,
where a cold restart spends the rest of max_iter without a verdict)."""
REFINE_ABOVE_KNOTS = 38
"""A first solve (no warm start) of more knots than this starts from a COARSE_KNOTS solve
interpolated onto its mesh (app.core.collocation.mesh_interpolation): at 160 knots a few seconds of CPU
instead of minutes from the guess. Building the coarse problem costs ~1.5 s of CPU now that
the NLP's derivatives are assembled from per-knot blocks (nlp.py), so refinement pays
whenever the mesh is finer than the coarse one."""
COARSE_KNOTS = 38
BASE_Z_LOW_RATIO = 0.4
"""Lowest base height, as a fraction of the straight-leg standing height (keeps IPOPT sane)."""
BASE_PITCH_BOUNDS_RAD = (-0.8, 0.8)
BASE_SPEED_MAX = 10.0
"""Bound on the base's x and z speeds [m/s] (loose: keeps IPOPT's iterates sane)."""
BASE_PITCH_RATE_MAX = 20.0
"""[rad/s]"""
GUESSES_KEPT = 4
"""Built-in guesses a problem keeps (GaitProblem._guess)."""


def _dm(matrix: np.ndarray) -> ca.DM:
    return ca.DM(matrix)


def _friction(c: Constrainer, force: Any, mu: Any) -> None:
    """The contact force (tangential, normal, normal) inside the friction pyramid."""
    total = force[1] + force[2]
    c.constrain(ca.vertcat(mu * total - force[0], mu * total + force[0]), 0.0, ca.inf, "friction")


class GaitProblem:
    """The NLP for one structure (knots, baseline); `solve` re-solves it for any slider values."""

    def __init__(
        self,
        robot: RobotModel | PlanarModel | None = None,
        knots: int = 38,
        baseline: bool = False,
        *,
        hessian: str = "exact",
    ) -> None:
        """Build the NLP for dircon_biped (or `robot`): `hessian` is "exact" (default, about 20
        iterations) or "limited-memory" (L-BFGS: thousands of iterations here, kept for
        comparison)."""
        if not isinstance(robot, RobotModel | PlanarModel | None):
            raise TypeError(f"GaitProblem's first argument is the robot, not {robot!r}")
        GaitSettings(knots=knots, baseline=baseline).validate()
        start = time.perf_counter()
        if robot is None:
            from app.core.robot.loading import load_robot

            robot = load_robot("dircon_biped")
        self.model = robot if isinstance(robot, PlanarModel) else PlanarModel(robot)
        self.layout = GaitLayout.from_knots(knots)
        self.structure = (knots, baseline)
        self.baseline = baseline
        self.nlp = SxNlp()
        self._build()
        options = dict(IPOPT_OPTIONS)
        if hessian != "exact":
            options["ipopt.hessian_approximation"] = "limited-memory"
        self.compiled: CompiledNlp = self.nlp.compile(options)
        self.compiled.warm_solver()  # built now, so that the first slider re-solve does not pay it
        self.build_s = time.perf_counter() - start
        """Time to build the NLP and IPOPT's derivative functions [s]."""
        self.last_good: GaitResult | None = None
        """The last converged result: the default warm start, kept through failed solves."""
        self._coarse: GaitProblem | None = None
        """The 38-knot problem whose solve starts a fine mesh's first solve, built on use."""
        self._guesses: dict[tuple[float, ...], np.ndarray] = {}
        """The built-in guess by the settings it depends on (a few kept): a per-node leg IK
        that costs about as much as a warm re-solve, the same for every sweep point that
        changes only weights or bounds."""

    # -- building ------------------------------------------------------------------------------

    def _build(self) -> None:
        nlp, m, L = self.nlp, self.model, self.layout
        N = L.n_nodes
        H, d, mu = nlp.parameter("H"), nlp.parameter("d"), nlp.parameter("mu")
        K0, K1, K2 = nlp.parameter("K0"), nlp.parameter("K1"), nlp.parameter("K2")
        K_impact = nlp.parameter("K_impact")
        B = np.zeros((m.nv, m.nu))
        B[BASE_DOF:] = np.eye(m.nu)
        Bd = _dm(B)

        q = [nlp.variable("q", m.nq) for _ in range(N)]
        v = [nlp.variable("v", m.nv) for _ in range(N)]
        a = [nlp.variable("a", m.nv) for _ in range(N)]
        u = [nlp.variable("u", m.nu) for _ in range(N)]
        lam = [nlp.variable("lam", 3) for _ in range(N)]
        if self.baseline:
            T = nlp.variable("T", 3)
            durations = (T[0], T[1], T[2])
            nlp.constrain(T[0] + T[1] + T[2] - H, tag="durations")
            x1 = nlp.variable("x1", 1)
            slack = None
        else:
            durations = L.symmetric_durations(H)
            slack = nlp.variable("slack", 1)
        steps = [durations[j] / (L.sizes[j] - 1) for j in range(3)]
        if self.baseline:
            foothold_args: tuple[tuple[Any, ...], ...] = ((), (x1,), (d,))
            step_args: tuple[Any, ...] = (T,)
        else:
            foothold_args = ((), (slack, d), (d,))
            step_args = (H,)

        knot_builders = [self._knot(j, Bd) for j in range(3)]
        interval_builders = [self._interval(j, Bd) for j in range(3)]
        energy: Any = 0
        smooth: Any = 0
        for k in range(N):
            j = L.mode_of(k)
            nlp.block(("knot", j), knot_builders[j], q[k], v[k], a[k], u[k], lam[k], mu,
                      *foothold_args[j])  # fmt: skip
            if k in (0, N - 1):  # the right foot's mid-swing
                swing = _dm(swing_z_rows(other(STANCE[j]))) @ m.contact_positions(q[k])
                nlp.constrain(swing, 0.0, 0.0, tag="clearance")
            energy += steps[j] * ca.sumsqr(u[k])
        self._knot_swing = list(nlp.g_blocks["swing"])
        assert len(self._knot_swing) == N
        """The swing-foot height rows of each node (the knots' swing rows come first)."""

        for j in range(3):
            nodes = list(L.nodes(j))
            if j == 1 and len(nodes) % 2 == 1:  # the left foot's mid-swing is a node
                mid_node = nodes[len(nodes) // 2]
                swing_mid = _dm(swing_z_rows("left")) @ m.contact_positions(q[mid_node])
                nlp.constrain(swing_mid, 0.0, 0.0, tag="clearance")
            for k in nodes[:-1]:
                gamma = nlp.variable("gamma", 3)
                lam_mid = nlp.variable("lam_mid", 3)
                nlp.block(("interval", j), interval_builders[j], q[k], v[k], a[k], u[k],
                          q[k + 1], v[k + 1], a[k + 1], u[k + 1], gamma, lam_mid, mu,
                          *step_args)  # fmt: skip
                if j == 1 and 2 * (k - nodes[0]) == len(nodes) - 2:  # the left foot's mid-swing
                    q_c = hermite_simpson(q[k], v[k], a[k], q[k + 1], v[k + 1], a[k + 1], steps[j])[
                        0
                    ]
                    swing_c = _dm(swing_z_rows("left")) @ m.contact_positions(q_c)
                    nlp.constrain(swing_c, 0.0, 0.0, tag="clearance")
                smooth += (
                    ca.sumsqr(q[k + 1] - q[k])
                    + ca.sumsqr(v[k + 1] - v[k])
                    + ca.sumsqr(u[k + 1] - u[k])
                )

        impact_loss = self._impacts(q, v, mu)
        advance = ca.vertcat(d, ca.DM.zeros(m.nq - 1))
        nlp.constrain(q[N - 1] - q[0] - advance, tag="periodicity")
        nlp.constrain(v[N - 1] - v[0], tag="periodicity")

        cost = POSTURE_WEIGHT * (ca.sumsqr(q[0][2:]) + ca.sumsqr(q[N - 1][2:])) + K0 * energy
        cost += K_impact * impact_loss
        if not self.baseline:
            left, right = (list(m.leg_joints[s]) for s in ("left", "right"))
            e0, e1 = L.last(0), L.last(1)
            for x in (q, v):  # ±exchange tolerance (0 for mirror-identical legs)
                nlp.constrain(x[e0][left] - x[e1][right], tag="exchange")
                nlp.constrain(x[e0][right] - x[e1][left], tag="exchange")
            assert slack is not None
            cost += K1 * slack**2 + K2 * smooth
        nlp.cost = cost

    def _foothold(self, j: int, *args: Any) -> Any:
        """Where mode j's stance foot stands (x) [m]: 0, or from the step's variables."""
        if j == 0:
            return 0.0
        if j == 2 or self.baseline:
            return args[-1] if j == 2 else args[0]
        slack_, d_ = args
        return (0.5 + slack_) * (0.0 + d_)

    def _step(self, j: int, arg: Any) -> Any:
        """The time step between two knots of mode j [s] (arg: T, or H for the symmetric gait)."""
        L = self.layout
        duration = arg[j] if self.baseline else L.symmetric_durations(arg)[j]
        return duration / (L.sizes[j] - 1)

    def _knot(self, j: int, Bd: Any) -> Callable[..., None]:
        """The constraints at one knot of mode j."""
        m = self.model
        S, swing_rows = _dm(stance_rows(STANCE[j])), _dm(swing_z_rows(other(STANCE[j])))

        def build(c: Constrainer, qk: Any, vk: Any, ak: Any, uk: Any, lamk: Any,
                  mu_: Any, *extra: Any) -> None:  # fmt: skip
            p = m.contact_positions(qk)
            Js = S @ m.contact_jacobian(qk)
            c.constrain(m.rnea(qk, vk, ak) - Bd @ uk - Js.T @ lamk, tag="dynamics")
            c.constrain(S @ p - ca.vertcat(self._foothold(j, *extra), 0.0, 0.0), tag="contact")
            c.constrain(Js @ vk, tag="contact")
            c.constrain(Js @ ak + S @ m.contact_jdot_v(qk, vk), tag="contact")
            _friction(c, lamk, mu_)
            c.constrain(swing_rows @ p, 0.0, 0.0, tag="swing")  # bounds set per solve

        return build

    def _interval(self, j: int, Bd: Any) -> Callable[..., None]:
        """The collocation constraints between two knots of mode j."""
        m = self.model
        S, swing_rows = _dm(stance_rows(STANCE[j])), _dm(swing_z_rows(other(STANCE[j])))

        def build(c: Constrainer, q0: Any, v0: Any, a0: Any, u0: Any, q1: Any, v1: Any,
                  a1: Any, u1: Any, gamma: Any, lam_mid: Any, mu_: Any, step: Any) -> None:  # fmt: skip
            q_c, v_c, qd_c, vd_c = hermite_simpson(q0, v0, a0, q1, v1, a1, self._step(j, step))
            Jc = S @ m.contact_jacobian(q_c)
            c.constrain(qd_c - v_c - Jc.T @ gamma, tag="dynamics")
            c.constrain(
                m.rnea(q_c, v_c, vd_c) - Bd @ (0.5 * (u0 + u1)) - Jc.T @ lam_mid,
                tag="dynamics",
            )
            _friction(c, lam_mid, mu_)
            # Bounds between the knots, at the collocation point (bounds set per solve).
            c.constrain(q_c[BASE_DOF:], tag="range_mid")
            c.constrain(v_c[BASE_DOF:], tag="speed_mid")
            c.constrain(swing_rows @ m.contact_positions(q_c), tag="swing")

        return build

    def _impacts(self, q: list[Any], v: list[Any], mu: Any) -> Any:
        """The two touch-downs' constraints; the kinetic energy they lose, ½ Δvᵀ M Δv [J]."""
        nlp, m, L = self.nlp, self.model, self.layout
        impact_loss: Any = 0
        for j in (0, 1):
            pre, post = L.last(j), L.first(j + 1)
            impulse = nlp.variable("impulse", 3)
            S_land = _dm(stance_rows(STANCE[j + 1]))
            nlp.constrain(q[post] - q[pre], tag="impact")
            nlp.constrain(
                m.mass_matrix(q[pre]) @ (v[post] - v[pre])
                - (S_land @ m.contact_jacobian(q[pre])).T @ impulse,
                tag="impact",
            )
            _friction(nlp, impulse, mu)
            landing = _dm(foot_rows(STANCE[j + 1])) @ m.contact_jacobian(q[pre]) @ v[pre]
            nlp.constrain(landing, tag="touchdown")  # |heel, toe velocity| before touch-down
            jump = v[post] - v[pre]
            impact_loss += 0.5 * ca.dot(jump, m.mass_matrix(q[pre]) @ jump)
            # The lifting foot's heel may not move down just after the impact. Its toe has no
            # such row: where the foot rolls off its toe (the optimum at a low K0) that row is
            # active and its gradient lies in the span of the impact and stance equalities, so
            # IPOPT's multipliers grow without bound and the solve stalls (K0 = 2 on
            # servo_biped: 1000 iterations). The toe stays above the floor by the swing rows
            # of the next collocation point and knots.
            heel = _dm(swing_z_rows(STANCE[j])[:1])
            lifting = heel @ m.contact_jacobian(q[post]) @ v[post]
            nlp.constrain(lifting, 0.0, ca.inf, tag="lifting")
        return impact_loss

    # -- solving -------------------------------------------------------------------------------

    def _parameters(self, s: GaitSettings) -> np.ndarray:
        values = {
            "H": s.H_s, "d": s.step_length_m, "mu": s.mu, "K0": s.K0, "K1": s.K1, "K2": s.K2,
            "K_impact": s.K_impact,
        }  # fmt: skip
        p = np.zeros(len(self.nlp.p_index))
        for name, i in self.nlp.p_index.items():
            p[i] = values[name]
        return p

    def _bounds(self, s: GaitSettings) -> tuple[np.ndarray, ...]:
        m, nlp = self.model, self.nlp
        lbx, ubx = np.full(nlp.nx, -np.inf), np.full(nlp.nx, np.inf)
        blocks = nlp.x_blocks
        h0 = m.standing_height_m
        z_low, z_high = BASE_Z_LOW_RATIO * h0, s.pelvis_height_ratio * h0
        lo_q = np.concatenate([[-np.inf, z_low, BASE_PITCH_BOUNDS_RAD[0]], m.lower])
        hi_q = np.concatenate([[np.inf, z_high, BASE_PITCH_BOUNDS_RAD[1]], m.upper])
        for side in ("left", "right"):
            knee = m.leg_joints[side][1]
            if m.bodies[knee - BASE_DOF + 1].axis_sign > 0:  # flexion = +q (foot moves back)
                lo_q[knee] = max(lo_q[knee], s.knee_flexion_min_rad)
            else:
                hi_q[knee] = min(hi_q[knee], -s.knee_flexion_min_rad)
        speed = [BASE_SPEED_MAX] * 2 + [BASE_PITCH_RATE_MAX] + [s.qd_max] * m.nu
        for sl in blocks["q"]:
            lbx[sl], ubx[sl] = lo_q, hi_q
        for sl in blocks["v"]:
            lbx[sl], ubx[sl] = -np.array(speed), np.array(speed)
        for sl in blocks["u"]:
            lbx[sl], ubx[sl] = -s.tau_max_Nm, s.tau_max_Nm
        for name in ("lam", "lam_mid", "impulse"):
            for sl in blocks[name]:
                lbx[sl.start + 1 : sl.stop] = 0.0  # vertical forces push
        if self.baseline:
            (sl,) = blocks["T"]
            lbx[sl] = np.array([0.05, 0.25, 0.05]) * s.H_s
            ubx[sl] = np.array([0.5, 0.75, 0.5]) * s.H_s
            (sl,) = blocks["x1"]
            lbx[sl], ubx[sl] = -0.5, s.step_length_m + 0.5
        else:
            (sl,) = blocks["slack"]
            lbx[sl], ubx[sl] = s.slack_a, s.slack_b
        lbg, ubg = self.compiled.lbg.copy(), self.compiled.ubg.copy()
        for sl in nlp.g_blocks["swing"]:
            lbg[sl], ubg[sl] = 0.0, s.swing_height_m
        L = self.layout
        for j in (0, 1):  # both soles are on the floor at a touch-down: q_post = q_pre
            for node in (L.last(j), L.first(j + 1)):
                # The landing foot before, the lifting foot after: their heights are 0 by the
                # stance rows of the node on the other side, so a bound here would only repeat
                # an equality, and an active inequality that repeats one leaves its multiplier
                # unbounded (IPOPT then stalls).
                sl = self._knot_swing[node]
                lbg[sl], ubg[sl] = -np.inf, np.inf
        for sl in nlp.g_blocks["range_mid"]:
            lbg[sl], ubg[sl] = m.lower, m.upper
        for sl in nlp.g_blocks["speed_mid"]:
            lbg[sl], ubg[sl] = -s.qd_max, s.qd_max
        for sl in nlp.g_blocks["touchdown"]:
            lbg[sl], ubg[sl] = -s.touchdown_speed_max_mps, s.touchdown_speed_max_mps
        for sl in nlp.g_blocks.get("exchange", []):
            lbg[sl], ubg[sl] = -m.exchange_tolerance, m.exchange_tolerance
        for sl in nlp.g_blocks["clearance"]:
            lbg[sl] = min(s.swing_clearance_m, s.swing_height_m)
            ubg[sl] = s.swing_height_m
        return lbx, ubx, lbg, ubg

    def _guess(self, s: GaitSettings) -> np.ndarray:
        """The built-in starting point for `s` (depends on H, step length and swing height)."""
        key = (s.H_s, s.step_length_m, s.swing_height_m)
        if key not in self._guesses:
            while len(self._guesses) >= GUESSES_KEPT:
                self._guesses.pop(next(iter(self._guesses)))
            self._guesses[key] = self._new_guess(s)
        return self._guesses[key].copy()

    def _new_guess(self, s: GaitSettings) -> np.ndarray:
        L, blocks = self.layout, self.nlp.x_blocks
        durations = np.array(L.symmetric_durations(s.H_s), dtype=float)
        times = L.node_times(durations)
        g = initial_guess(self.model, L, times, s.H_s, s.step_length_m, s.swing_height_m)
        x = np.zeros(self.nlp.nx)
        for name in ("q", "v", "a", "u", "lam"):
            for k, sl in enumerate(blocks[name]):
                x[sl] = g[name][k]
        pairs = [(k, k + 1) for j in range(3) for k in list(L.nodes(j))[:-1]]
        for (k0, k1), sl in zip(pairs, blocks["lam_mid"], strict=True):
            x[sl] = 0.5 * (g["lam"][k0] + g["lam"][k1])
        if self.baseline:
            x[blocks["T"][0]] = durations
            x[blocks["x1"][0]] = 0.5 * s.step_length_m
        return x

    def solve(
        self,
        settings: GaitSettings,
        warm_start: GaitResult | None = None,
        iteration_callback: IterationCallback | None = None,
        *,
        cold: bool = False,
        start_z: np.ndarray | None = None,
    ) -> GaitResult:
        """Solve for `settings`. Starts from `warm_start` if it is a converged result of this
        structure, else from the last converged solution of this problem, else (or with
        cold=True) from the built-in guess; a warm start that does not converge within
        WARM_ITERATIONS_BEFORE_FALLBACK iterations restarts cold (the result's
        `warm_iterations_before_cold` says so). Never raises for bad settings or a failed solve:
        the result says what happened, and `last_good` keeps the last converged gait.
        `iteration_callback(iteration, objective, violation)` runs at every IPOPT iteration and
        may return True to stop the solve. `start_z` (nx,) is a primal starting point given
        directly (e.g. a coarser mesh's optimum interpolated, app.core.collocation.mesh_interpolation)."""
        try:
            settings.validate()
        except GaitSettingsError as error:
            return GaitResult.refused(settings, f"invalid settings: {error}")
        if settings.structure != self.structure:
            return GaitResult.refused(
                settings,
                f"invalid settings: this problem is built for knots = {self.structure[0]}, "
                f"baseline = {self.structure[1]}; build another GaitProblem",
            )
        start = self.last_good
        if (
            isinstance(warm_start, GaitResult)
            and warm_start.converged
            and warm_start.structure == self.structure
        ):
            start = warm_start
        x0 = self._guess(settings) if cold or start is None else start.z
        if (
            start_z is None
            and start is None
            and not cold
            and self.structure[0] > REFINE_ABOVE_KNOTS
        ):
            refined = self._refined_start(settings, iteration_callback)
            if isinstance(refined, GaitResult):  # stopped during the coarse solve
                return dataclasses.replace(refined, settings=settings)
            start_z = refined
        if start_z is not None:
            if start_z.shape != (self.nlp.nx,):
                raise ValueError(f"start_z has shape {start_z.shape}, need ({self.nlp.nx},)")
            x0, start = start_z, None
        lbx, ubx, lbg, ubg = self._bounds(settings)
        run = functools.partial(
            self.compiled.run, p=self._parameters(settings),
            lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg, callback=iteration_callback,
        )  # fmt: skip
        warm_iterations = 0
        try:
            if cold or start is None:
                outcome = run(np.clip(x0, lbx, ubx), max_iter=settings.max_iter)
            else:
                outcome, warm_iterations = self._warm_run(
                    run, np.clip(x0, lbx, ubx), lambda: np.clip(self._guess(settings), lbx, ubx),
                    start, settings.max_iter, iteration_callback,
                )  # fmt: skip
        except RuntimeError as error:
            return GaitResult.refused(settings, f"the solver failed: {error}")
        result = read_result(outcome, settings, self.model, self.layout, self.nlp.x_blocks)
        result = dataclasses.replace(result, warm_iterations_before_cold=warm_iterations)
        if result.converged:
            self.last_good = result
            return result
        scales = Scales(
            self.model.mass_kg * self.model.gravity, self.model.standing_height_m,
            self.model.gravity,
        )  # fmt: skip
        blame = hardest_constraint(outcome, self.nlp, (lbg, ubg), settings, (lbx, ubx), scales)
        return dataclasses.replace(result, blame=blame)

    def _refined_start(
        self, settings: GaitSettings, iteration_callback: IterationCallback | None = None
    ) -> np.ndarray | GaitResult | None:
        """The COARSE_KNOTS optimum for these settings on this mesh, None if it fails, or the
        coarse result if `iteration_callback` stopped it. The callback sees the coarse
        solve's iterations first, then (from 0 again) the fine solve's."""
        if self._coarse is None:
            self._coarse = GaitProblem(self.model, COARSE_KNOTS, self.baseline)
        coarse = self._coarse.solve(
            dataclasses.replace(settings, knots=COARSE_KNOTS),
            iteration_callback=iteration_callback,
        )
        if coarse.ipopt_status == "User_Requested_Stop":
            return coarse
        if not coarse.converged:
            return None
        return interpolate_point(self._coarse, coarse.z, self)

    def _has_multipliers(self, result: GaitResult) -> bool:
        return result.lam_x.shape == (self.nlp.nx,) and result.lam_g.shape == (self.nlp.ng,)

    def _warm_run(
        self,
        run: Callable[..., SolveOutcome],
        x_warm: np.ndarray,
        x_guess: Callable[[], np.ndarray],
        start: GaitResult,
        max_iter: int,
        iteration_callback: IterationCallback | None,
    ) -> tuple[SolveOutcome, int]:
        """Warm start from `start` (primal-dual when it has multipliers), restarting cold from
        the built-in guess (`x_guess()`, computed only then) when that has not converged
        within WARM_ITERATIONS_BEFORE_FALLBACK iterations or failed otherwise (but not with FINAL_WARM_STATUSES). Returns the outcome
        and the iterations of the abandoned warm attempt (0 when none was abandoned); seconds
        and iterations of both attempts add up, and the callback sees the cold attempt's
        iterations numbered on from the warm ones."""
        budget = min(max_iter, WARM_ITERATIONS_BEFORE_FALLBACK)
        multipliers = (start.lam_x, start.lam_g) if self._has_multipliers(start) else None
        warm = run(x_warm, max_iter=budget, multipliers=multipliers)
        if warm.converged or warm.raw_status in FINAL_WARM_STATUSES or budget >= max_iter:
            return warm, 0
        offset = warm.iterations + 1  # the callback saw iterations 0 … warm.iterations

        def numbered_on(iteration: int, objective: float, violation: float) -> bool | None:
            assert iteration_callback is not None
            return iteration_callback(offset + iteration, objective, violation)

        callback = numbered_on if iteration_callback is not None else None
        cold = run(x_guess(), max_iter=max_iter - warm.iterations, callback=callback)
        outcome = dataclasses.replace(
            cold,
            seconds=warm.seconds + cold.seconds,
            iterations=warm.iterations + cold.iterations,
        )
        return outcome, warm.iterations
