"""The whole-body QP's records: the configuration-dependent terms, one sample or a batch of
them, one sample's whole input, the weights resolved for one robot and one sample's solution
(shared by the full QP, app.core.dynamics.wbc_qp, and the reduced one, wbc_reduced)."""

from __future__ import annotations

import dataclasses

import numpy as np


@dataclasses.dataclass(frozen=True)
class Terms:
    """The configuration-dependent quantities of one sample."""

    M: np.ndarray
    """Mass matrix, shape (nv, nv)."""
    h: np.ndarray
    """Coriolis, centrifugal and gravity terms, shape (nv,)."""
    Phi: np.ndarray
    """Generalised force of the pyramid coefficients, Φᵀλ = Phi β, shape (nv, 32)."""
    J_feet: np.ndarray
    """Both feet's 6-D Jacobians (LOCAL), shape (12, nv)."""
    drift_feet: np.ndarray
    """J̇ q̇ of the feet (LOCAL spatial acceleration at q̈ = 0), shape (12,)."""
    J_loop: np.ndarray
    """Jacobian of p_a − p_b of every loop (world), shape (3 * n_loops, nv)."""
    drift_loop: np.ndarray
    """J̇_loop q̇, shape (3 * n_loops,)."""
    com_acc: np.ndarray
    """The plan's CoM acceleration [m/s²], shape (3,)."""


@dataclasses.dataclass(frozen=True)
class SampleInput:
    """What the QP of one sample is asked: its terms, the state and what the plan wants."""

    terms: Terms
    v: np.ndarray
    """Generalised velocity, shape (nv,)."""
    qdd_des: np.ndarray
    """The plan's generalised acceleration, shape (nv,)."""
    contacts: np.ndarray
    """(left, right) sole on the floor, shape (2,) of bool."""
    com_error: np.ndarray
    """x̄, the CoM state's error fed back by the LQR, shape (6,); zero for a feed-forward."""


@dataclasses.dataclass(frozen=True)
class TermsBatch:
    """Terms of n samples stacked (robots without loops): M (n, nv, nv), h (n, nv),
    Phi (n, nv, 32), J_feet (n, 12, nv), drift_feet (n, 12), com_acc (n, 3)."""

    M: np.ndarray
    h: np.ndarray
    Phi: np.ndarray
    J_feet: np.ndarray
    drift_feet: np.ndarray
    com_acc: np.ndarray


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
