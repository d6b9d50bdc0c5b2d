"""The paper's three-mode symmetric gait NLP (eq. 7): its variables, constraints and cost.

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

from collections.abc import Callable
from typing import Any

import casadi as ca
import numpy as np

from app.core.collocation.nlp import Constrainer, SxNlp
from app.core.collocation.planar_model import BASE_DOF, PlanarModel
from app.core.collocation.transcription import (
    STANCE,
    GaitLayout,
    foot_rows,
    hermite_simpson,
    other,
    stance_rows,
    swing_z_rows,
)

POSTURE_WEIGHT = 0.05
"""Weight of the light initial/final posture terms (eq. 7's l_0, l_f)."""


def _dm(matrix: np.ndarray) -> ca.DM:
    return ca.DM(matrix)


def _friction(c: Constrainer, force: Any, mu: Any) -> None:
    """The contact force (tangential, normal, normal) inside the friction pyramid."""
    total = force[1] + force[2]
    c.constrain(ca.vertcat(mu * total - force[0], mu * total + force[0]), 0.0, ca.inf, "friction")


def build_gait_nlp(
    nlp: SxNlp, model: PlanarModel, layout: GaitLayout, baseline: bool
) -> list[slice]:
    """Add the gait's variables, constraints and cost to `nlp`; the swing-foot height rows of
    each node (the knots' swing rows, in node order)."""
    builder = _GaitNlpBuilder(nlp, model, layout, baseline)
    builder._build()
    return builder._knot_swing


class _GaitNlpBuilder:
    """The NLP's construction, mode by mode (the knots' and intervals' blocks, the touch-downs,
    periodicity, exchange and cost)."""

    def __init__(self, nlp: SxNlp, model: PlanarModel, layout: GaitLayout, baseline: bool) -> None:
        self.nlp, self.model, self.layout, self.baseline = nlp, model, layout, baseline
        self._knot_swing: list[slice] = []

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
