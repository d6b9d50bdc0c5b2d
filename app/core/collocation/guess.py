"""The cold-start guess: a plausible walking motion built by planar leg inverse kinematics.

The base moves forward at the gait's mean speed at a constant height with the knees slightly
bent; the stance foot stays on its foothold, the swing foot travels on a half-sine arc. Joint
velocities and accelerations are central differences of that motion; torques and contact forces
solve the knot dynamics M a + h = B u + J_sᵀ λ exactly (9 equations, 6 + 3 unknowns).
"""

from __future__ import annotations

import numpy as np

from app.core.collocation.planar_model import BASE_DOF, PlanarModel, evaluate
from app.core.collocation.transcription import STANCE, GaitLayout, stance_rows

BASE_HEIGHT_RATIO = 0.97
"""Guess base height: this fraction of the standing height (knees bent a little)."""
ARC_HEIGHT_M = 0.05


def _foot_target(side: str, t: float, H: float, d: float) -> tuple[float, float]:
    """(x of the sole centre, lift of the sole) of a foot at time t of the nominal gait.

    Left stands at 0 on [0, H/4] and at d on [3H/4, H], swings on [H/4, 3H/4]; right stands at
    d/2 on [H/4, 3H/4] and swings from −d/2 to d/2 (around t = 0) and d/2 to 3d/2 (around H)."""
    if side == "left":
        if t <= 0.25 * H:
            return 0.0, 0.0
        if t >= 0.75 * H:
            return d, 0.0
        s = (t - 0.25 * H) / (0.5 * H)
        return d * s, float(np.sin(np.pi * s))
    if 0.25 * H <= t <= 0.75 * H:
        return 0.5 * d, 0.0
    s = (t + 0.25 * H) / (0.5 * H) if t < 0.25 * H else (t - 0.75 * H) / (0.5 * H)
    start = -0.5 * d if t < 0.25 * H else 0.5 * d
    return start + d * s, float(np.sin(np.pi * s))


class LegPosture:
    """Planar leg IK: the three leg joints that put a foot flat at a target."""

    def __init__(self, model: PlanarModel) -> None:
        self.model = model
        q0 = np.zeros(model.nq)
        self.standing_height = -float(evaluate(model.contact_positions, q0)[1])
        self.q = q0
        for side in ("left", "right"):
            hip, knee, ankle = model.leg_joints[side][:3]
            signs = [model.bodies[j - BASE_DOF + 1].axis_sign for j in (hip, knee, ankle)]
            self.q[[hip, knee, ankle]] = np.array([-0.2, 0.4, -0.2]) * signs

    def solve(
        self,
        base: np.ndarray,
        targets: dict[str, tuple[float, float]],
        warm: np.ndarray | None = None,
    ) -> np.ndarray:
        """Planar q with base (x, z, pitch) and each foot's sole centre flat at (x, z) [m];
        Gauss–Newton from `warm` (default: the last solution)."""
        q = (self.q if warm is None else warm).copy()
        q[:BASE_DOF] = base
        for side, (x, z) in targets.items():
            S = stance_rows(side)
            joints = self.model.leg_joints[side]
            target = np.array([x, z, z])
            for _ in range(30):
                residual = S @ evaluate(self.model.contact_positions, q) - target
                if np.abs(residual).max() < 1e-10:
                    break
                J = S @ evaluate(self.model.contact_jacobian, q)[:, joints]
                q[joints] -= np.linalg.lstsq(J, residual, rcond=None)[0]
            q[joints] = np.clip(
                q[joints], self.model.lower[joints - BASE_DOF], self.model.upper[joints - BASE_DOF]
            )
        self.q = q
        return q

    def solve_many(self, bases: np.ndarray, targets: dict[str, np.ndarray]) -> np.ndarray:
        """`solve` for many poses at once: (n, nq) planar q, row i with base `bases[i]`
        (x, z, pitch) and each foot's sole centre flat at `targets[side][i]` (x, z) [m].
        Gauss–Newton on all rows together from this posture, to a residual of 1e-12 m."""
        n = len(bases)
        q = np.tile(self.q, (n, 1))
        q[:, :BASE_DOF] = bases
        positions = self.model.contact_positions.map(n)
        jacobians = self.model.contact_jacobian.map(n)
        for side, xz in targets.items():
            S = stance_rows(side)
            joints = np.asarray(self.model.leg_joints[side])
            target = np.column_stack([xz[:, 0], xz[:, 1], xz[:, 1]])
            for _ in range(30):
                residual = np.asarray(positions(q.T).full()).T @ S.T - target  # (n, 3)
                if np.abs(residual).max() < 1e-12:
                    break
                J = (S @ _stacked(jacobians(q.T), n))[:, :, joints]
                q[:, joints] -= (np.linalg.pinv(J) @ residual[:, :, None])[:, :, 0]
            lower, upper = (
                limit[joints - BASE_DOF] for limit in (self.model.lower, self.model.upper)
            )
            q[:, joints] = np.clip(q[:, joints], lower, upper)
        return q


def initial_guess(
    model: PlanarModel,
    layout: GaitLayout,
    times: np.ndarray,
    H: float,
    d: float,
    swing_height: float,
) -> dict[str, np.ndarray]:
    """Arrays q, v, a (N, nq), u (N, nu), lam (N, 3) at the node times."""
    posture = LegPosture(model)
    z_base = BASE_HEIGHT_RATIO * posture.standing_height
    lift = min(ARC_HEIGHT_M, 0.5 * swing_height)
    eps = 1e-3
    n = layout.n_nodes
    # Each node's pose, and the poses eps before and after it (rows 3k, 3k + 1, 3k + 2).
    pose_times = (np.asarray(times, dtype=float)[:, None] + np.array([-eps, 0.0, eps])).ravel()
    bases = np.column_stack(
        [d * pose_times / H, np.full(pose_times.size, z_base), np.zeros(pose_times.size)]
    )
    targets = {}
    for side in ("left", "right"):
        feet = np.array([_foot_target(side, float(t), H, d) for t in pose_times])
        targets[side] = np.column_stack([feet[:, 0], lift * feet[:, 1]])
    poses = posture.solve_many(bases, targets).reshape(n, 3, model.nq)
    before, q, after = poses[:, 0], poses[:, 1], poses[:, 2]
    v = (after - before) / (2 * eps)
    a = (after - 2 * q + before) / eps**2
    # Torques and contact forces from the knot dynamics M a + h = B u + J_sᵀ λ, all nodes at once.
    tau = np.asarray(model.rnea.map(n)(q.T, v.T, a.T).full()).T  # (n, nv)
    J = _stacked(model.contact_jacobian.map(n)(q.T), n)  # (n, 8, nv)
    stance = np.stack([stance_rows(STANCE[layout.mode_of(k)]) for k in range(n)])
    B = np.zeros((model.nv, model.nu))
    B[BASE_DOF:] = np.eye(model.nu)
    system = np.concatenate([np.broadcast_to(B, (n, *B.shape)), (stance @ J).transpose(0, 2, 1)], 2)
    solution = np.linalg.solve(system, tau[:, :, None])[:, :, 0]
    u, lam = solution[:, : model.nu], solution[:, model.nu :]
    return {"q": q, "v": v, "a": a, "u": u, "lam": lam}


def _stacked(jacobians: object, n: int) -> np.ndarray:
    """(n, 8, nv) from a mapped contact Jacobian's (8, n·nv) output."""
    J = np.asarray(jacobians.full())  # type: ignore[attr-defined]
    return J.reshape(J.shape[0], n, -1).transpose(1, 0, 2)
