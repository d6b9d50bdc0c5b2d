"""LQR for the CoM double integrator of the spring-compensation paper (Wang et al. 2023, Sec. 3).

The CoM model is eq. 1: x = [p_com, v_com] ∈ R⁶, u = a_com ∈ R³,
ẋ = A x + B u with A = [[0, I], [0, 0]], B = [[0], [I]], and the output y = [I 0] x + a·u.
With the cost J = ∫ xᵀQx + uᵀRu dt (eq. 2), Q = q·I₆ and R = r·I₃ (paper: q = 10, r = 0.1),
the three axes decouple into identical double integrators, whose continuous algebraic Riccati
equation AᵀS + SA − SBR⁻¹BᵀS + Q = 0 has the closed-form stabilising solution (per axis)

    s_pv = √(q r),   s_vv = √(r (q + 2 s_pv)),   s_pp = s_pv s_vv / r,

and the gain K = R⁻¹BᵀS = [√(q/r), √((q + 2√(q r))/r)] per axis. J*(x̄) = x̄ᵀ S x̄ (eq. 3).
No numerical Riccati solver is used here, so the tests can check this against scipy's.
"""

from __future__ import annotations

import math

import numpy as np

from app.core.errors import StudioError

A_COM = np.block([[np.zeros((3, 3)), np.eye(3)], [np.zeros((3, 3)), np.zeros((3, 3))]])
"""State matrix of eq. 1, shape (6, 6)."""
B_COM = np.vstack([np.zeros((3, 3)), np.eye(3)])
"""Input matrix of eq. 1, shape (6, 3)."""


def lqr_com(q_weight: float = 10.0, r_weight: float = 0.1) -> tuple[np.ndarray, np.ndarray]:
    """(K, S) of the CoM LQR with Q = q_weight·I₆ and R = r_weight·I₃ (paper: 10 and 0.1).

    K, shape (3, 6): the optimal feedback ū = −K x̄ [m/s² per m, per m/s].
    S, shape (6, 6): the Riccati solution, J*(x̄) = x̄ᵀ S x̄ (eq. 3).
    """
    if not (math.isfinite(q_weight) and q_weight > 0.0):
        raise StudioError(f"LQR state weight must be a positive number, got {q_weight!r}")
    if not (math.isfinite(r_weight) and r_weight > 0.0):
        raise StudioError(f"LQR input weight must be a positive number, got {r_weight!r}")
    s_pv = math.sqrt(q_weight * r_weight)
    s_vv = math.sqrt(r_weight * (q_weight + 2.0 * s_pv))
    s_pp = s_pv * s_vv / r_weight
    eye = np.eye(3)
    S = np.block([[s_pp * eye, s_pv * eye], [s_pv * eye, s_vv * eye]])
    K = (B_COM.T @ S) / r_weight
    return K, S
