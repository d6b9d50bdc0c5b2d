"""The whole-body QP's per-sample terms from pinocchio: M, h, the contact wrench map Φ of the
friction pyramids' edges at the sole corners, the feet's and loops' Jacobians and drifts, the
CoM acceleration; one sample or a batch (wbc_qp's docstring has the QP they fill).

QpKinematicsMixin is one part of app.core.dynamics.wbc_qp.WholeBodyQp (state set up by its
__init__); pyramid_edges and the corner/edge counts are the contact model's layout.
"""

from __future__ import annotations

import time

import numpy as np
import pinocchio as pin

from app.core.dynamics.wbc_reduced import ReducedQp
from app.core.dynamics.wbc_terms import Terms, TermsBatch

N_EDGES = 4
N_CORNERS = 4


def pyramid_edges(mu: float) -> np.ndarray:
    """w_i = n + μ d_i as columns, shape (3, 4): n = world z, d = +x, −x, +y, −y (eq. 11)."""
    return np.array(
        [[mu, -mu, 0.0, 0.0], [0.0, 0.0, mu, -mu], [1.0, 1.0, 1.0, 1.0]],
    )


def _moment_map(W: np.ndarray) -> np.ndarray:
    """r_c × w_i = −[w_i]× r_c: the moments (3, 16) of the 16 β of a foot from its corner
    offsets (4, 3), as a (12, 48) map: row 3c + j (offset of corner c, axis j), column
    16k + 4c + i."""
    moment_map = np.zeros((3 * N_CORNERS, 3 * N_CORNERS * N_EDGES))
    for corner in range(N_CORNERS):
        for i in range(N_EDGES):
            w_i = W[:, i]
            minus_skew = -np.array(
                [[0.0, -w_i[2], w_i[1]], [w_i[2], 0.0, -w_i[0]], [-w_i[1], w_i[0], 0.0]]
            )
            for k in range(3):
                moment_map[
                    3 * corner : 3 * corner + 3, N_CORNERS * N_EDGES * k + N_EDGES * corner + i
                ] = minus_skew[k]
    return moment_map


class QpKinematicsMixin:
    """The per-sample terms' part of WholeBodyQp."""

    model: pin.Model
    data: pin.Data
    nv: int
    mass: float
    gravity: np.ndarray
    zero_v: np.ndarray
    foot_ids: list[int]
    corners_array: np.ndarray
    loop_ids: list[tuple[int, int]]
    reduced: ReducedQp | None
    _no_loop: np.ndarray
    _no_drift: np.ndarray
    _W_tiled: np.ndarray
    _moment_map: np.ndarray

    def kinematics(self, q: np.ndarray, v: np.ndarray, qdd_des: np.ndarray) -> Terms:
        """Every configuration-dependent term of one sample. With the reduced QP one pinocchio
        pass (computeAllTerms: M, h, joint Jacobians and the drift accelerations at q̈ = 0);
        for the full QP five, as before (CoM with the plan's q̈, crba, nle, joint Jacobians,
        kinematics at q̈ = 0). Then a handful of batched numpy products for both feet."""
        model, data, nv = self.model, self.data, self.nv
        if self.reduced is not None:
            pin.computeAllTerms(model, data, q, v)
            M, h = data.M.copy(), data.nle.copy()  # overwritten by the next sample
            # Newton on the whole robot: the base's linear rows of M q̈ + h are the net
            # external force m (c̈ − g) in the base frame (free-flyer velocity is LOCAL).
            force_base = M[:3] @ qdd_des + h[:3]
            com_acc = data.oMi[1].rotation @ force_base / self.mass + self.gravity
        else:
            pin.centerOfMass(model, data, q, v, qdd_des)
            com_acc = data.acom[0].copy()
            M = pin.crba(model, data, q).copy()  # data.M is overwritten by the next sample
            h = pin.nonLinearEffects(model, data, q, v).copy()
            pin.computeJointJacobians(model, data, q)
            pin.forwardKinematics(model, data, q, v, self.zero_v)
        pin.updateFramePlacements(model, data)
        left, right = self.foot_ids
        J_feet = np.empty((2, 6, nv))
        J_feet[0] = pin.getFrameJacobian(model, data, left, pin.LOCAL)
        J_feet[1] = pin.getFrameJacobian(model, data, right, pin.LOCAL)
        drift_feet = np.empty(12)
        drift_feet[:6] = pin.getFrameAcceleration(model, data, left, pin.LOCAL).vector
        drift_feet[6:] = pin.getFrameAcceleration(model, data, right, pin.LOCAL).vector
        R = np.empty((2, 3, 3))
        R[0] = data.oMf[left].rotation
        R[1] = data.oMf[right].rotation
        J_world = (R[:, None] @ J_feet.reshape(2, 2, 3, nv)).reshape(2, 6, nv)
        offsets = self.corners_array @ R.transpose(0, 2, 1)  # corners from the foot origin, world
        Phi = (
            (J_world.transpose(0, 2, 1) @ self._wrench_maps(offsets))
            .transpose(1, 0, 2)
            .reshape(nv, 2 * N_CORNERS * N_EDGES)
        )
        if self.loop_ids:
            J_loop, drift_loop = self._loop_terms()
        else:
            J_loop, drift_loop = self._no_loop, self._no_drift
        return Terms(
            M=M,
            h=h,
            Phi=Phi,
            J_feet=J_feet.reshape(12, nv),
            drift_feet=drift_feet,
            J_loop=J_loop,
            drift_loop=drift_loop,
            com_acc=com_acc,
        )

    def kinematics_batch(
        self, q: np.ndarray, v: np.ndarray, qdd_des: np.ndarray
    ) -> tuple[TermsBatch, np.ndarray]:
        """`kinematics` of n samples (reduced QP only): one pinocchio pass per sample, then
        the numpy products for all of them at once. Also the wall time of each sample's
        pinocchio calls [s], shape (n,)."""
        model, data, nv, n = self.model, self.data, self.nv, len(q)
        left, right = self.foot_ids
        M, h = np.empty((n, nv, nv)), np.empty((n, nv))
        J_feet, drift = np.empty((n, 2, 6, nv)), np.empty((n, 12))
        R, R_base = np.empty((n, 2, 3, 3)), np.empty((n, 3, 3))
        seconds = np.empty(n)
        local = pin.LOCAL
        for k in range(n):
            begin = time.perf_counter()
            pin.computeAllTerms(model, data, q[k], v[k])
            pin.updateFramePlacements(model, data)
            M[k], h[k], R_base[k] = data.M, data.nle, data.oMi[1].rotation
            J_feet[k, 0] = pin.getFrameJacobian(model, data, left, local)
            J_feet[k, 1] = pin.getFrameJacobian(model, data, right, local)
            drift[k, :6] = pin.getFrameAcceleration(model, data, left, local).vector
            drift[k, 6:] = pin.getFrameAcceleration(model, data, right, local).vector
            R[k, 0], R[k, 1] = data.oMf[left].rotation, data.oMf[right].rotation
            seconds[k] = time.perf_counter() - begin
        force_base = (M[:, :3] @ qdd_des[:, :, None])[:, :, 0] + h[:, :3]
        com_acc = (R_base @ force_base[:, :, None])[:, :, 0] / self.mass + self.gravity
        J_world = (R[:, :, None] @ J_feet.reshape(n, 2, 2, 3, nv)).reshape(n, 2, 6, nv)
        offsets = self.corners_array @ R.transpose(0, 1, 3, 2)  # (n, 2, 4, 3), world
        G = np.empty((n, 2, 6, N_CORNERS * N_EDGES))
        G[:, :, :3] = self._W_tiled
        G[:, :, 3:] = (offsets.reshape(n, 2, 3 * N_CORNERS) @ self._moment_map).reshape(
            n, 2, 3, N_CORNERS * N_EDGES
        )
        Phi = (
            (J_world.transpose(0, 1, 3, 2) @ G)
            .transpose(0, 2, 1, 3)
            .reshape(n, nv, 2 * N_CORNERS * N_EDGES)
        )
        batch = TermsBatch(M, h, Phi, J_feet.reshape(n, 12, nv), drift, com_acc)
        return batch, seconds

    def terms_at(self, batch: TermsBatch, k: int) -> Terms:
        """Sample k of a batch as the Terms `solve` takes."""
        return Terms(
            M=batch.M[k],
            h=batch.h[k],
            Phi=batch.Phi[k],
            J_feet=batch.J_feet[k],
            drift_feet=batch.drift_feet[k],
            J_loop=self._no_loop,
            drift_loop=self._no_drift,
            com_acc=batch.com_acc[k],
        )

    def _loop_terms(self) -> tuple[np.ndarray, np.ndarray]:
        """J_loop (3 n_loops, nv) and J̇_loop q̇ (3 n_loops,) from the current pinocchio data."""
        model, data = self.model, self.data
        world = pin.LOCAL_WORLD_ALIGNED
        J_loop, drift_loop = [], []
        for a, b in self.loop_ids:
            J_a = pin.getFrameJacobian(model, data, a, world)[:3]
            J_b = pin.getFrameJacobian(model, data, b, world)[:3]
            J_loop.append(J_a - J_b)
            drift_loop.append(
                pin.getFrameClassicalAcceleration(model, data, a, world).linear
                - pin.getFrameClassicalAcceleration(model, data, b, world).linear
            )
        return np.vstack(J_loop), np.concatenate(drift_loop)

    def _wrench_maps(self, offsets: np.ndarray) -> np.ndarray:
        """Wrench at each foot's origin (force; moment, world axes) of its 16 β, (2, 6, 16),
        from the corners' offsets (2, 4, 3).

        Column (c, i) is [w_i; r_c × w_i] with r_c the corner's offset from the foot origin;
        r_c × w_i = −[w_i]× r_c is linear in the offsets, one product with a constant map.
        """
        G = np.empty((2, 6, N_CORNERS * N_EDGES))
        G[:, :3] = self._W_tiled
        G[:, 3:] = (offsets.reshape(2, 3 * N_CORNERS) @ self._moment_map).reshape(
            2, 3, N_CORNERS * N_EDGES
        )
        return G
