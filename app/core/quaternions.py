"""Every quaternion-order conversion of the studio, in one place.

pinocchio stores quaternions as (x, y, z, w); viser and three.js as (w, x, y, z).
"""

from __future__ import annotations

import numpy as np


def wxyz_to_xyzw(quat_wxyz: np.ndarray) -> np.ndarray:
    """viser order (w, x, y, z) -> pinocchio order (x, y, z, w)."""
    q = np.asarray(quat_wxyz, dtype=float)
    return np.concatenate([q[..., 1:4], q[..., 0:1]], axis=-1)


def matrix_to_wxyz(rotation: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of a 3x3 rotation matrix, with w >= 0."""
    r = np.asarray(rotation, dtype=float)
    trace = r[0, 0] + r[1, 1] + r[2, 2]
    if trace > 0.0:
        s = 2.0 * np.sqrt(trace + 1.0)
        q = np.array(
            [0.25 * s, (r[2, 1] - r[1, 2]) / s, (r[0, 2] - r[2, 0]) / s, (r[1, 0] - r[0, 1]) / s]
        )
    else:
        i = int(np.argmax(np.diag(r)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2.0 * np.sqrt(max(1.0 + r[i, i] - r[j, j] - r[k, k], 1e-300))
        q = np.empty(4)
        q[0] = (r[k, j] - r[j, k]) / s
        q[1 + i] = 0.25 * s
        q[1 + j] = (r[j, i] + r[i, j]) / s
        q[1 + k] = (r[k, i] + r[i, k]) / s
    q /= np.linalg.norm(q)
    return q if q[0] >= 0.0 else -q


def wxyz_to_matrix(quat_wxyz: np.ndarray) -> np.ndarray:
    """3x3 rotation matrix of a (w, x, y, z) quaternion (normalised first)."""
    w, x, y, z = np.asarray(quat_wxyz, dtype=float) / np.linalg.norm(quat_wxyz)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def xyzquat_to_matrices(xyzquat: np.ndarray) -> np.ndarray:
    """Rigid transforms (T, 4, 4) of pinocchio's (x, y, z, qx, qy, qz, qw) rows (T, 7)."""
    x, y, z, w = (xyzquat[:, 3 + i] for i in range(4))
    out = np.zeros((len(xyzquat), 4, 4))
    out[:, 0, 0] = 1.0 - 2.0 * (y * y + z * z)
    out[:, 0, 1] = 2.0 * (x * y - z * w)
    out[:, 0, 2] = 2.0 * (x * z + y * w)
    out[:, 1, 0] = 2.0 * (x * y + z * w)
    out[:, 1, 1] = 1.0 - 2.0 * (x * x + z * z)
    out[:, 1, 2] = 2.0 * (y * z - x * w)
    out[:, 2, 0] = 2.0 * (x * z - y * w)
    out[:, 2, 1] = 2.0 * (y * z + x * w)
    out[:, 2, 2] = 1.0 - 2.0 * (x * x + y * y)
    out[:, :3, 3] = xyzquat[:, :3]
    out[:, 3, 3] = 1.0
    return out


def matrices_to_xyzquat(T: np.ndarray) -> np.ndarray:
    """Pinocchio's (x, y, z, qx, qy, qz, qw) rows (T, 7) of rigid transforms (T, 4, 4). The
    quaternion's sign follows Eigen's conversion (pinocchio's `SE3ToXYZQUAT`)."""
    m = T[:, :3, :3]
    n = len(T)
    quat = np.empty((n, 4))  # x, y, z, w
    trace = m[:, 0, 0] + m[:, 1, 1] + m[:, 2, 2]
    positive = trace > 0.0
    if positive.all():  # an upright base, the usual case: no masked copies
        t = np.sqrt(trace + 1.0)
        half = 0.5 / t
        quat[:, 3] = 0.5 * t
        quat[:, 0] = (m[:, 2, 1] - m[:, 1, 2]) * half
        quat[:, 1] = (m[:, 0, 2] - m[:, 2, 0]) * half
        quat[:, 2] = (m[:, 1, 0] - m[:, 0, 1]) * half
        return np.concatenate([T[:, :3, 3], quat], axis=1)
    if positive.any():
        mp = m[positive]
        t = np.sqrt(trace[positive] + 1.0)
        half = 0.5 / t
        quat[positive, 3] = 0.5 * t
        quat[positive, 0] = (mp[:, 2, 1] - mp[:, 1, 2]) * half
        quat[positive, 1] = (mp[:, 0, 2] - mp[:, 2, 0]) * half
        quat[positive, 2] = (mp[:, 1, 0] - mp[:, 0, 1]) * half
    diagonal = np.stack([m[:, 0, 0], m[:, 1, 1], m[:, 2, 2]], axis=1)
    largest = np.zeros(n, dtype=int)  # Eigen's choice: the first of the largest diagonal terms
    largest[diagonal[:, 1] > diagonal[:, 0]] = 1
    largest[diagonal[:, 2] > diagonal[np.arange(n), largest]] = 2
    for i in range(3):
        rows = ~positive & (largest == i)
        if not rows.any():
            continue
        j, k = (i + 1) % 3, (i + 2) % 3
        mr = m[rows]
        t = np.sqrt(mr[:, i, i] - mr[:, j, j] - mr[:, k, k] + 1.0)
        half = 0.5 / t
        quat[rows, i] = 0.5 * t
        quat[rows, 3] = (mr[:, k, j] - mr[:, j, k]) * half
        quat[rows, j] = (mr[:, j, i] + mr[:, i, j]) * half
        quat[rows, k] = (mr[:, k, i] + mr[:, i, k]) * half
    return np.concatenate([T[:, :3, 3], quat], axis=1)
