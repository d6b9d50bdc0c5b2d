"""Task-space interpolants: time laws on [0, 1] and the blend of two placements.

- min_jerk: s(τ) = 10τ³ − 15τ⁴ + 6τ⁵, zero velocity and acceleration at both ends;
- trapezoid: a trapezoidal speed profile (constant acceleration for a ramp fraction of the
  segment, cruise, symmetric braking), the hybrid-leg paper's "T-shaped" curve (Sec. 4.1);
- blend: position lerp and rotation slerp, R0·exp(s·log(R0ᵀR1)); Blend does the same with
  what does not depend on s computed once (a segment's samples all blend the same two ends),
  for one s or (`at_many`) for a whole segment's samples at once.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pinocchio as pin

TRAPEZOID_RAMP = 0.25
"""Fraction of a trapezoid segment spent accelerating (and as much braking); the hybrid-leg
paper's "T-shaped" speed curve gives no ramp length."""


def min_jerk(tau: float) -> float:
    """Minimum-jerk time law s(τ) = 10τ³ − 15τ⁴ + 6τ⁵ on [0, 1]."""
    return tau**3 * (10.0 - 15.0 * tau + 6.0 * tau**2)


def trapezoid(tau: float, ramp: float = TRAPEZOID_RAMP) -> float:
    """Time law with a trapezoidal speed: constant acceleration for `ramp`, cruise, mirror."""
    peak = 1.0 / (1.0 - ramp)
    if tau < ramp:
        return 0.5 * peak * tau**2 / ramp
    if tau > 1.0 - ramp:
        return 1.0 - 0.5 * peak * (1.0 - tau) ** 2 / ramp
    return peak * (tau - 0.5 * ramp)


def min_jerk_many(tau: np.ndarray) -> np.ndarray:
    """`min_jerk` of each τ in an array."""
    return tau**3 * (10.0 - 15.0 * tau + 6.0 * tau**2)


def trapezoid_many(tau: np.ndarray, ramp: float = TRAPEZOID_RAMP) -> np.ndarray:
    """`trapezoid` of each τ in an array."""
    peak = 1.0 / (1.0 - ramp)
    return np.where(
        tau < ramp,
        0.5 * peak * tau**2 / ramp,
        np.where(
            tau > 1.0 - ramp, 1.0 - 0.5 * peak * (1.0 - tau) ** 2 / ramp, peak * (tau - 0.5 * ramp)
        ),
    )


def blend(T0: np.ndarray, T1: np.ndarray, s: float) -> np.ndarray:
    """Placement a fraction s of the way from T0 to T1: position lerp, rotation slerp."""
    T = np.eye(4)
    T[:3, 3] = T0[:3, 3] + s * (T1[:3, 3] - T0[:3, 3])
    T[:3, :3] = T0[:3, :3] @ pin.exp3(s * pin.log3(T0[:3, :3].T @ T1[:3, :3]))
    return T


@dataclasses.dataclass(frozen=True)
class Blend:
    """`blend(T0, T1, s)` for one pair of placements, the same numbers for every s, with
    the rotation's log and the position's span taken once."""

    position: np.ndarray
    span: np.ndarray
    rotation: np.ndarray
    turn: np.ndarray

    @classmethod
    def of(cls, T0: np.ndarray, T1: np.ndarray) -> Blend:
        return cls(
            T0[:3, 3].copy(),
            T1[:3, 3] - T0[:3, 3],
            T0[:3, :3].copy(),
            pin.log3(T0[:3, :3].T @ T1[:3, :3]),
        )

    def at(self, s: float) -> np.ndarray:
        T = np.eye(4)
        T[:3, 3] = self.position + s * self.span
        T[:3, :3] = self.rotation @ pin.exp3(s * self.turn)
        return T

    def at_many(self, s: np.ndarray) -> np.ndarray:
        """`at` of each s in an array (m,): placements (m, 4, 4). The rotation's exponential
        by Rodrigues' formula, exp(φ·[u]×) = I + sin φ·[u]× + (1 − cos φ)·[u]×², u the unit axis
        of `turn`, φ = s·|turn|."""
        s = np.asarray(s, dtype=float)
        out = np.zeros((s.size, 4, 4))
        out[:, 3, 3] = 1.0
        out[:, :3, 3] = self.position + s[:, None] * self.span
        angle = float(np.sqrt(self.turn @ self.turn))
        if angle == 0.0:
            out[:, :3, :3] = self.rotation
            return out
        x, y, z = self.turn / angle
        K = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
        phi = s * angle
        exp = (
            np.eye(3)
            + np.sin(phi)[:, None, None] * K
            + (1.0 - np.cos(phi))[:, None, None] * (K @ K)
        )
        out[:, :3, :3] = self.rotation @ exp
        return out
