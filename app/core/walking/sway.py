"""Lateral CoM sway over the footholds, from the linear inverted pendulum (LIPM).

With the CoM at a constant height z_c, the lateral zero-moment point is p = y − ÿ / ω²,
ω² = g / z_c. The ZMP must stay on the stance sole, so its reference p_ref(t) is the stance
foot's y in single support and moves smoothly between the feet in double support. y(t) is the
least-squares fit on the sample grid (step dt):

    minimise Σ_k (p_k − p_ref,k)² + w Σ_k (Δ³y_k / dt³)²     p_k = y_k − (y_k+1 − 2 y_k + y_k−1)/(ω² dt²)
    subject to y = 0 and ẏ = 0 at both ends (standing still, centred between the feet),

a linear least-squares problem solved once for the whole walk (the pendulum is unstable
forwards in time, so the sway must anticipate each step: a global fit does that, like preview
control). The small jerk weight w only removes sample-to-sample noise.
"""

from __future__ import annotations

import numpy as np

JERK_WEIGHT = 1e-9
"""w [s⁶]: tiny against the ZMP term, enough to keep y smooth between samples."""


def smoothstep(s: np.ndarray) -> np.ndarray:
    """Quintic 0 → 1 on s ∈ [0, 1] with zero slope and curvature at both ends."""
    s = np.clip(s, 0.0, 1.0)
    return s**3 * (10.0 - 15.0 * s + 6.0 * s**2)


def lateral_sway(p_ref: np.ndarray, dt: float, omega: float) -> tuple[np.ndarray, np.ndarray]:
    """(y, p): CoM lateral position [m] and its ZMP [m] on the grid, for the ZMP reference."""
    n = len(p_ref)
    second = np.zeros((n, n))
    for k in range(1, n - 1):
        second[k, k - 1 : k + 2] = (1.0, -2.0, 1.0)
    zmp = np.eye(n) - second / (omega**2 * dt**2)
    third = np.zeros((max(n - 3, 0), n))
    for k in range(n - 3):
        third[k, k : k + 4] = (-1.0, 3.0, -3.0, 1.0)
    # Rest at both ends: y_0 = y_1 = y_{n-2} = y_{n-1} = 0; solve for the inner samples.
    inner = np.arange(2, n - 2)
    A = np.vstack([zmp[:, inner], np.sqrt(JERK_WEIGHT) / dt**3 * third[:, inner]])
    b = np.concatenate([p_ref, np.zeros(len(third))])
    y = np.zeros(n)
    y[inner] = np.linalg.solve(A.T @ A, A.T @ b)  # normal equations: A has full column rank
    return y, zmp @ y
