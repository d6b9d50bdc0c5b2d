"""Why a solve ended short of its targets: what holds the closest reachable pose back.

At the closest pose q* the IK's QP step vanishes, so its first-order (KKT) conditions hold:

    −∇c_goals(q*) = ∇c_torso(q*) + Σ_i μ_i ∇g_i(q*) + J_held(q*)ᵀ λ,      μ_i ≥ 0

with c_goals the soft targets' squared errors (moving foot, pelvis, CoM target; the QP's
weights), c_torso the soft torso hold, g_i ≤ 0 the inequalities that are active there (a joint
at a limit, the CoM on an edge of the shrunk support polygon) and J_held the held feet's
Jacobian. Projected onto the null space N of J_held, λ drops out, and the non-negative least
squares fit of −Nᵀ∇c_goals by the candidates' columns gives each one's share of the push,
μ_i·(a_i·b)/(b·b) with b the projected push and a_i a candidate's column (the shares sum to
at most 1, whatever the constraints' units): a joint at a limit the targets do not push
against gets μ = 0 and is not named.

Computed only for a result that missed a target (one Jacobian pass, a Cholesky solve — an SVD
where J_held is ill-conditioned — and a small NNLS).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pinocchio as pin

AT_LIMIT_RAD = np.deg2rad(0.5)
"""A joint this close to a bound counts as at it (the solve stops within a step of it)."""
ON_EDGE_M = 5e-4
"""The CoM this close to an edge of the shrunk support polygon counts as held by it."""
SHARE_NAMED = 0.15
"""A blocker is named when it takes at least this fraction of the targets' push."""
NO_PUSH = 1e-9
"""[m²/rad] A push this small in the free directions: nothing first-order is blocked (a
singular pose, e.g. a straight leg, where no joint motion brings the target closer)."""
NOTHING_PUSHED = (
    "no joint motion brings the target closer from here: a straight leg cannot bend by a "
    "small step (Ready pose bends the knees)"
)
"""The shortfall's line where the push vanishes in the free directions (NO_PUSH): said as it
is, not as a "held back by" reason."""
WELL_CONDITIONED = 1e-8
"""JJᵀ of the held feet's Jacobian J is solved by its Cholesky factor when LAPACK's estimate of
its reciprocal condition number (1-norm) is above this: the projector is then within ~1e-8
of the SVD's; else the SVD decides J's rank (_null_space)."""


@dataclasses.dataclass(frozen=True)
class Goal:
    """A soft frame target of the solve: frame id, 4x4 target, the QP's weights."""

    frame_id: int
    T_world_target: np.ndarray
    position_weight: float = 1.0
    orientation_weight: float = 1.0


@dataclasses.dataclass(frozen=True)
class Bounded:
    """The joints with limits: names, velocity indices, configuration indices, bounds [rad]."""

    names: tuple[str, ...]
    idx_v: np.ndarray
    idx_q: np.ndarray
    lower: np.ndarray
    upper: np.ndarray


@dataclasses.dataclass(frozen=True)
class Situation:
    """Everything at the closest pose the diagnosis needs, besides the configuration."""

    goals: tuple[Goal, ...]
    held_frame_ids: tuple[int, ...]
    bounded: Bounded
    com_target_xy: np.ndarray | None = None
    com_target_weight: float = 0.0
    polygon_edges: tuple[np.ndarray, np.ndarray] | None = None
    """(outward unit normals (E, 2), offsets (E,)) of the support polygon already shrunk by
    the margin: the CoM constraint n·com ≤ offset; None when the polygon was not enforced."""
    torso: tuple[int, np.ndarray, float] | None = None
    """(frame id, held 3x3 orientation, weight) of the soft torso hold."""


def blockers(model: pin.Model, data: pin.Data, q: np.ndarray, situation: Situation) -> list[str]:
    """What holds the pose back from its targets, most pushed first, one line each (empty:
    nothing is pushed against, e.g. the iterations stopped early)."""
    shares = reason_shares(model, data, q, situation)
    if isinstance(shares, str):
        return [shares]
    return [label for label, share in shares.items() if share >= SHARE_NAMED]


def reason_shares(
    model: pin.Model, data: pin.Data, q: np.ndarray, situation: Situation
) -> dict[str, float] | str:
    """Each candidate reason's part of the targets' push at q, largest first: the push's
    component along what the non-negative combination of the reasons' gradients (NNLS)
    gives it, over the push's squared norm (the parts sum to at most 1, whatever the units of
    the constraints); or one line when nothing pushes."""
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    push = np.zeros(model.nv)
    """−∇c_goals (the direction the targets pull q in)."""
    for goal in situation.goals:
        J = pin.getFrameJacobian(model, data, goal.frame_id, pin.LOCAL_WORLD_ALIGNED)
        T = data.oMf[goal.frame_id]
        delta = goal.T_world_target[:3, 3] - T.translation
        turn = T.rotation @ pin.log3(T.rotation.T @ goal.T_world_target[:3, :3])
        push += goal.position_weight * J[:3].T @ delta + goal.orientation_weight * J[3:].T @ turn
    J_com = None
    if situation.com_target_xy is not None or situation.polygon_edges is not None:
        J_com = pin.jacobianCenterOfMass(model, data, False)[:2]  # the kinematics at q: above
        if situation.com_target_xy is not None:
            miss = situation.com_target_xy - data.com[0][:2]
            push += situation.com_target_weight * J_com.T @ miss
    labels, rows = _candidates(model, data, q, situation, J_com)
    held = [pin.getFrameJacobian(model, data, fid, pin.LOCAL) for fid in situation.held_frame_ids]
    projected = _free(np.vstack(held) if held else None, np.array([push, *rows]))
    b, A = projected[0], projected[1:].T
    if float(b @ b) < NO_PUSH**2:
        return NOTHING_PUSHED
    if not rows:
        return {}
    scale = math.sqrt(float((A * A).sum(axis=0).max()))
    if scale == 0.0:
        return {}
    from scipy.optimize import nnls  # scipy loads when a pose falls short, not with the IK

    mu, _ = nnls(A / scale, b / scale)
    shares = mu * (A.T @ b) / float(b @ b)  # each reason's part of the push (sum ≤ 1)
    out: dict[str, float] = {}
    for label, share in zip(labels, shares.tolist(), strict=True):
        out[label] = out.get(label, 0.0) + share  # several edges: one reason
    return dict(sorted(out.items(), key=lambda x: -x[1]))


def _candidates(
    model: pin.Model,
    data: pin.Data,
    q: np.ndarray,
    situation: Situation,
    J_com: np.ndarray | None,
) -> tuple[list[str], list[np.ndarray]]:
    """The active inequalities and the torso hold at q, each with the gradient [nv] of its
    constraint (g_i ≤ 0) or cost, not yet projected (the frames and Jacobians at q)."""
    labels: list[str] = []
    rows: list[np.ndarray] = []
    bounded = situation.bounded
    angles = q[bounded.idx_q]
    at_upper = np.abs(angles - bounded.upper) < AT_LIMIT_RAD
    at_lower = np.abs(angles - bounded.lower) < AT_LIMIT_RAD
    sides = ((at_upper, bounded.upper, 1.0, "upper"), (at_lower, bounded.lower, -1.0, "lower"))
    for i in np.flatnonzero(at_upper | at_lower).tolist():  # few: the joints at a limit
        for at, bounds, sign, word in sides:
            if at[i]:
                row = np.zeros(model.nv)
                row[bounded.idx_v[i]] = sign  # the gradient of sign·(q_i − bound) ≤ 0
                rows.append(row)
                degrees = np.rad2deg(bounds[i])
                labels.append(f"{bounded.names[i]} at its {word} limit ({degrees:.1f}°)")
    if situation.polygon_edges is not None and J_com is not None:
        normals, offsets = situation.polygon_edges
        on_edge = offsets - normals @ data.com[0][:2] < ON_EDGE_M
        if on_edge.any():
            rows.extend(normals[on_edge] @ J_com)
            labels.extend(["the CoM kept over the support polygon"] * int(on_edge.sum()))
    if situation.torso is not None:
        frame_id, R_held, weight = situation.torso
        R = data.oMf[frame_id].rotation
        turn = R @ pin.log3(R.T @ R_held)
        J = pin.getFrameJacobian(model, data, frame_id, pin.LOCAL_WORLD_ALIGNED)
        rows.append(-weight * (turn @ J[3:]))  # ∇c_torso
        labels.append("the torso kept as it was (drag the pelvis to lean it)")
    return labels, rows


def _free(J_held: np.ndarray | None, X: np.ndarray) -> np.ndarray:
    """The rows of X (k × nv) projected onto the motions that keep the held feet in place,
    the null space of J_held: X·P with P = I − J⁺J, the orthogonal projector.

    Every quantity the diagnosis uses is a norm or an inner product of projected vectors,
    the same from P·x as from Nᵀ·x for an orthonormal basis N of that null space (P = N·Nᵀ).
    Where JJᵀ is well conditioned (one foot under a floating base: always), P·x = x − Jᵀz
    with JJᵀz = Jx (LAPACK's Cholesky solve dposv, its condition estimate dpocon: no SVD);
    otherwise (both feet of legs with fewer than six joints: J rank-deficient) N comes from
    J's full SVD."""
    if J_held is None:
        return X
    from scipy.linalg import lapack  # loaded with nnls, when a pose falls short

    gram = J_held @ J_held.T
    factor, Z, info = lapack.dposv(gram, J_held @ X.T)
    if info == 0:
        rcond, _ = lapack.dpocon(factor, float(np.abs(gram).sum(axis=0).max()))
        if rcond > WELL_CONDITIONED:
            return X - (J_held.T @ Z).T
    N = _null_space(J_held)
    return (X @ N) @ N.T


def _null_space(A: np.ndarray, rtol: float = 1e-10) -> np.ndarray:
    """Orthonormal basis (columns) of A's null space, from its full SVD."""
    _, sigma, Vt = np.linalg.svd(A, full_matrices=True)
    rank = int(np.sum(sigma > rtol * sigma[0])) if sigma.size else 0
    return Vt[rank:].T
