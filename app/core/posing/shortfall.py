"""Why a solve ended short of its targets: what holds the closest reachable pose back.

At the closest pose q* the IK's QP step vanishes, so its first-order (KKT) conditions hold:

    −∇c_goals(q*) = ∇c_torso(q*) + Σ_i μ_i ∇g_i(q*) + J_held(q*)ᵀ λ,      μ_i ≥ 0

with c_goals the soft targets' squared errors (moving foot, pelvis, CoM target; the QP's
weights), c_torso the soft torso hold, g_i ≤ 0 the inequalities that are active there (a joint
at a limit, the CoM on an edge of the shrunk support polygon) and J_held the held feet's
Jacobian. Projected onto the null space N of J_held, λ drops out, and the non-negative least
squares fit of −Nᵀ∇c_goals by the candidates' columns gives each one's share of the push:
a joint at a limit the targets do not push against gets μ = 0 and is not named.

Computed only for a result that missed a target (one Jacobian pass, an SVD, a small NNLS).
"""

from __future__ import annotations

import dataclasses

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
        J_com = pin.jacobianCenterOfMass(model, data, q, False)[:2]
        if situation.com_target_xy is not None:
            miss = situation.com_target_xy - data.com[0][:2]
            push += situation.com_target_weight * J_com.T @ miss
    held = [pin.getFrameJacobian(model, data, fid, pin.LOCAL) for fid in situation.held_frame_ids]
    N = _null_space(np.vstack(held)) if held else np.eye(model.nv)
    b = N.T @ push
    if float(b @ b) < NO_PUSH**2:
        return ["no joint motion brings the target closer from here (a straight leg?)"]
    labels: list[str] = []
    columns: list[np.ndarray] = []
    bounded = situation.bounded
    angles = q[bounded.idx_q]
    for name, iv, angle, lower, upper in zip(
        bounded.names, bounded.idx_v, angles, bounded.lower, bounded.upper, strict=True
    ):
        for bound, sign, word in ((upper, 1.0, "upper"), (lower, -1.0, "lower")):
            if abs(angle - bound) < AT_LIMIT_RAD:
                column = np.zeros(model.nv)
                column[iv] = sign  # the gradient of sign·(q_i − bound) ≤ 0
                columns.append(N.T @ column)
                labels.append(f"{name} at its {word} limit ({np.rad2deg(bound):.1f}°)")
    if situation.polygon_edges is not None and J_com is not None:
        normals, offsets = situation.polygon_edges
        on_edge = offsets - normals @ data.com[0][:2] < ON_EDGE_M
        if np.any(on_edge):
            for normal in normals[on_edge]:
                columns.append(N.T @ (J_com.T @ normal))
                labels.append("the CoM kept over the support polygon")
    if situation.torso is not None:
        frame_id, R_held, weight = situation.torso
        R = data.oMf[frame_id].rotation
        turn = R @ pin.log3(R.T @ R_held)
        J = pin.getFrameJacobian(model, data, frame_id, pin.LOCAL_WORLD_ALIGNED)
        columns.append(N.T @ (-weight * J[3:].T @ turn))  # ∇c_torso
        labels.append("the torso kept as it was (drag the pelvis to lean it)")
    if not columns:
        return []
    A = np.column_stack(columns)
    scale = float(np.linalg.norm(A, axis=0).max())
    if scale == 0.0:
        return []
    from scipy.optimize import nnls  # scipy loads when a pose falls short, not with the IK

    mu, _ = nnls(A / scale, b / scale)
    shares = mu * (A.T @ b) / float(b @ b) / scale
    out: dict[str, float] = {}
    for label, share in zip(labels, shares, strict=True):
        out[label] = out.get(label, 0.0) + float(share)  # several edges: one reason
    return [
        label for label, share in sorted(out.items(), key=lambda x: -x[1]) if share >= SHARE_NAMED
    ]


def _null_space(A: np.ndarray, rtol: float = 1e-10) -> np.ndarray:
    """Orthonormal basis (columns) of A's null space, from its full SVD."""
    _, sigma, Vt = np.linalg.svd(A, full_matrices=True)
    rank = int(np.sum(sigma > rtol * sigma[0])) if sigma.size else 0
    return Vt[rank:].T
