"""DIRCON transcription pieces: the three-mode knot layout, Hermite–Simpson collocation, and the
stance-foot constraint rows.

Layout (paper section 3.1): one complete gait is three modes, mode0 = second half of the left
support phase (LSP), mode1 = right support phase (RSP), mode2 = first half of the next LSP.
Each mode has its own nodes; the first node of mode1 and of mode2 is a *virtual knot*
(q_pre, v_post) of the touch-down that starts it (eq. 3–4). With `knots` real knots there are
knots + 2 nodes: mode0 and mode2 get the same number, (N + 2) // 4 each, mode1 the rest, so
the right foot's mid-swing falls on node 0 (and, by periodicity, the last node).

Collocation (eq. 2, Hermite–Simpson with DIRCON's corrections): between nodes k and k+1 of a
mode, with step h,

    q_c = (q_k + q_k+1)/2 + h/8 (v_k − v_k+1),      q̇_c = 3/(2h)(q_k+1 − q_k) − (v_k + v_k+1)/4
    v_c = (v_k + v_k+1)/2 + h/8 (a_k − a_k+1),      v̇_c = 3/(2h)(v_k+1 − v_k) − (a_k + a_k+1)/4

    q̇_c = v_c + J(q_c)ᵀ γ                         (velocity correction γ)
    M(q_c) v̇_c + h(q_c, v_c) = B u_c + J(q_c)ᵀ λ̄    (force correction λ̄, u_c = (u_k + u_k+1)/2)

Knots carry the accelerations a_k as variables with the implicit dynamics
M a_k + h = B u_k + Jᵀ λ_k and the kinematic constraints φ = 0, φ̇ = J v = 0,
φ̈ = J a + J̇ v = 0 of the stance foot.

Stance foot rows: the planar foot touches the ground at the mid-points of its rear and front
sole edges (two-point contact). Of their four coordinates only three are independent for a
rigid foot, so the constraint is φ = (mean x − foothold, z_heel, z_toe) and the force
λ = (f_x, f_z heel, f_z toe): a flat foot's f_x acts equally at either point.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

STANCE = ("left", "right", "left")
"""Stance foot of mode0, mode1, mode2."""
SIDES = ("left", "right")


def other(side: str) -> str:
    return "right" if side == "left" else "left"


@dataclasses.dataclass(frozen=True)
class GaitLayout:
    """Nodes of the three modes for a given number of real knots."""

    knots: int
    sizes: tuple[int, int, int]
    """Nodes per mode, virtual knots included."""

    @classmethod
    def from_knots(cls, knots: int) -> GaitLayout:
        total = knots + 2
        n0 = (total + 2) // 4
        return cls(knots, (n0, total - 2 * n0, n0))

    @property
    def n_nodes(self) -> int:
        return sum(self.sizes)

    def first(self, mode: int) -> int:
        return sum(self.sizes[:mode])

    def last(self, mode: int) -> int:
        return self.first(mode) + self.sizes[mode] - 1

    def nodes(self, mode: int) -> range:
        return range(self.first(mode), self.last(mode) + 1)

    def mode_of(self, node: int) -> int:
        return int(np.searchsorted(np.cumsum(self.sizes), node, side="right"))

    def node_times(self, durations: np.ndarray) -> np.ndarray:
        """Time of every node [s] for mode durations (T0, T1, T2); virtual knots repeat the
        time of the node before them."""
        starts = np.concatenate([[0.0], np.cumsum(durations)[:2]])
        return np.concatenate(
            [starts[j] + np.linspace(0.0, durations[j], self.sizes[j]) for j in range(3)]
        )

    def symmetric_durations(self, H: Any) -> tuple[Any, Any, Any]:
        """LSP = RSP = H/2 (eq. 6); mode0 and mode2 split the LSP in proportion to their
        intervals, so one step size h serves both. Fixing the split only fixes where in the
        LSP the periodic gait starts."""
        i0, i2 = self.sizes[0] - 1, self.sizes[2] - 1
        return 0.5 * H * i0 / (i0 + i2), 0.5 * H, 0.5 * H * i2 / (i0 + i2)


def hermite_simpson(
    q0: Any, v0: Any, a0: Any, q1: Any, v1: Any, a1: Any, h: Any
) -> tuple[Any, ...]:
    """(q_c, v_c, q̇_c, v̇_c) at the interval's mid-point from the cubic Hermite splines."""
    q_c = 0.5 * (q0 + q1) + h / 8.0 * (v0 - v1)
    v_c = 0.5 * (v0 + v1) + h / 8.0 * (a0 - a1)
    qd_c = 1.5 / h * (q1 - q0) - 0.25 * (v0 + v1)
    vd_c = 1.5 / h * (v1 - v0) - 0.25 * (a0 + a1)
    return q_c, v_c, qd_c, vd_c


def stance_rows(side: str) -> np.ndarray:
    """S (3 × 8): φ's rows from the 8 contact coordinates (left heel x z, left toe x z, right …)."""
    base = 0 if side == "left" else 4
    S = np.zeros((3, 8))
    S[0, base], S[0, base + 2] = 0.5, 0.5  # mean x of heel and toe
    S[1, base + 1] = 1.0  # heel z
    S[2, base + 3] = 1.0  # toe z
    return S


def swing_z_rows(side: str) -> np.ndarray:
    """(2 × 8): heel z and toe z of a foot."""
    base = 0 if side == "left" else 4
    S = np.zeros((2, 8))
    S[0, base + 1] = S[1, base + 3] = 1.0
    return S


def point_forces(stance_force: np.ndarray, side: str) -> np.ndarray:
    """(…, 4, 2) world forces (f_x, f_z) [N] at the 4 contact points from the stance foot's
    λ = (f_x, f_z heel, f_z toe); f_x is split in proportion to f_z (inside each cone when the
    total is)."""
    lam = np.asarray(stance_force, dtype=float)
    out = np.zeros((*lam.shape[:-1], 4, 2))
    fz = lam[..., 1:3]
    total = fz.sum(axis=-1, keepdims=True)
    share = np.where(np.abs(total) > 1e-12, fz / np.where(total == 0.0, 1.0, total), 0.5)
    first = 0 if side == "left" else 2
    out[..., first : first + 2, 0] = lam[..., :1] * share
    out[..., first : first + 2, 1] = fz
    return out


def foot_rows(side: str) -> np.ndarray:
    """(4 × 8): heel x, heel z, toe x, toe z of a foot."""
    base = 0 if side == "left" else 4
    S = np.zeros((4, 8))
    S[np.arange(4), base + np.arange(4)] = 1.0
    return S
