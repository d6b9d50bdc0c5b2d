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

    def pose(t: float) -> np.ndarray:
        targets = {}
        for side in ("left", "right"):
            x, s = _foot_target(side, t, H, d)
            targets[side] = (x, lift * s)
        return posture.solve(np.array([d * t / H, z_base, 0.0]), targets)

    eps = 1e-3
    n = layout.n_nodes
    q = np.empty((n, model.nq))
    v = np.empty((n, model.nv))
    a = np.empty((n, model.nv))
    u = np.empty((n, model.nu))
    lam = np.empty((n, 3))
    B = np.zeros((model.nv, model.nu))
    B[BASE_DOF:] = np.eye(model.nu)
    for k, t in enumerate(times):
        before, now, after = pose(t - eps), pose(t), pose(t + eps)
        q[k] = now
        v[k] = (after - before) / (2 * eps)
        a[k] = (after - 2 * now + before) / eps**2
        side = STANCE[layout.mode_of(k)]
        Js = stance_rows(side) @ evaluate(model.contact_jacobian, now)
        tau = evaluate(model.rnea, now, v[k], a[k])
        solution = np.linalg.solve(np.hstack([B, Js.T]), tau)
        u[k], lam[k] = solution[: model.nu], solution[model.nu :]
    return {"q": q, "v": v, "a": a, "u": u, "lam": lam}
