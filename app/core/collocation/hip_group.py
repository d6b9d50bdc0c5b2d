"""A hip that pitches through joints that are not pitch joints (Roban S14).

Roban S14's hip is three co-located joints: a first axis tilted 45° in the y-z plane, then
roll (x), then yaw (z). None turns about y, yet together they can turn the thigh by any pitch
α: the angles θ of the group solve (product of exponentials, axes a_i at the neutral pose in
the parent's frame)

    exp([a₁] θ₁) exp([a₂] θ₂) exp([a₃] θ₃) = R_y(α),

by Newton on log₃ with the space Jacobian J_s(θ) = [a₁, R₁ a₂, R₁R₂ a₃]. The planner then uses
one *virtual* pitch joint α there; its velocity maps to θ̇ = J_s(θ)⁻¹ ŷ α̇.

Approximation. The two intermediate bodies of the group (Roban: 0.43 kg and 2.5 kg) do not
turn by R_y(α) but by R₁ and R₁R₂ (up to ~0.3 rad of yaw away at α = 0.3 rad); the planar model
moves them with the thigh. Their CoMs lie within a few centimetres of the hip centre, so the
error is small but not zero: tests bound it against pinocchio, and the whole-body QP checks
the walk on the true model.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pinocchio as pin

NEWTON_ITERATIONS = 30
NEWTON_TOLERANCE = 1e-13
RANGE_STEP_RAD = 0.01
"""Resolution of the virtual joint's range scan [rad]."""


@dataclasses.dataclass(frozen=True)
class HipGroup:
    """A group of co-located revolute joints acting as one pitch joint."""

    names: tuple[str, ...]
    axes: np.ndarray
    """(3, 3): row i is joint i's axis in the group parent's frame at the neutral pose."""
    idx_q: np.ndarray
    idx_v: np.ndarray
    lower: np.ndarray
    upper: np.ndarray

    def rotations(self, theta: np.ndarray) -> list[np.ndarray]:
        """R₁, R₁R₂, R₁R₂R₃."""
        out, R = [], np.eye(3)
        for axis, angle in zip(self.axes, theta, strict=True):
            R = R @ pin.exp3(axis * angle)
            out.append(R)
        return out

    def jacobian(self, theta: np.ndarray) -> np.ndarray:
        """J_s(θ): the thigh's angular velocity (parent frame) per θ̇, (3, 3)."""
        Rs = self.rotations(theta)
        return np.column_stack([self.axes[0], Rs[0] @ self.axes[1], Rs[1] @ self.axes[2]])

    def angles(self, alpha: float, start: np.ndarray | None = None) -> np.ndarray:
        """θ with the product of the group's rotations equal to R_y(α)."""
        theta = np.zeros(3) if start is None else np.array(start, dtype=float)
        target = pin.exp3(np.array([0.0, alpha, 0.0]))
        for _ in range(NEWTON_ITERATIONS):
            error = pin.log3(self.rotations(theta)[-1] @ target.T)
            if np.abs(error).max() < NEWTON_TOLERANCE:
                break
            theta = theta - np.linalg.solve(self.jacobian(theta), error)
        return theta

    def pitch(self, theta: np.ndarray) -> float:
        """α of group angles θ (the pitch part of their rotation)."""
        R = self.rotations(theta)[-1]
        return float(np.arctan2(R[0, 2], R[0, 0]))

    def rates(self, alpha: float) -> np.ndarray:
        """θ̇ per α̇: J_s(θ(α))⁻¹ ŷ, (3,)."""
        return np.linalg.solve(self.jacobian(self.angles(alpha)), np.array([0.0, 1.0, 0.0]))

    def pitch_range(self) -> tuple[float, float]:
        """The interval of α around 0 whose angles stay within the joints' limits [rad]."""
        bounds = []
        for direction in (-1.0, 1.0):
            alpha, theta = 0.0, np.zeros(3)
            while abs(alpha) < np.pi / 2:
                step = alpha + direction * RANGE_STEP_RAD
                theta_next = self.angles(step, theta)
                if np.any(theta_next < self.lower) or np.any(theta_next > self.upper):
                    break
                alpha, theta = step, theta_next
            bounds.append(alpha)
        return bounds[0], bounds[1]


def find_hip_group(
    model: pin.Model, chain: list[int], axes: np.ndarray, origins: np.ndarray
) -> tuple[int, ...] | None:
    """The first run of ≥ 3 consecutive 1-DOF joints of a leg chain at one point whose axes
    span 3-D (a spherical hip), or None."""
    for start in range(len(chain) - 2):
        run = [chain[start]]
        for jid in chain[start + 1 :]:
            if model.joints[jid].nq != 1 or np.linalg.norm(origins[jid] - origins[run[0]]) > 1e-9:
                break
            run.append(jid)
        if len(run) >= 3 and model.joints[run[0]].nq == 1:
            group = run[:3]
            if abs(np.linalg.det(np.array([axes[j] for j in group]))) > 1e-3:
                return tuple(group)
    return None


def make_hip_group(model: pin.Model, group: tuple[int, ...], axes: np.ndarray) -> HipGroup:
    """The HipGroup of pinocchio joints `group` (world axes at the neutral pose: the base is
    unrotated there, so they are also the parent frame's)."""
    idx_q = np.array([model.joints[j].idx_q for j in group])
    return HipGroup(
        names=tuple(model.names[j] for j in group),
        axes=np.array([axes[j] for j in group]),
        idx_q=idx_q,
        idx_v=np.array([model.joints[j].idx_v for j in group]),
        lower=model.lowerPositionLimit[idx_q].copy(),
        upper=model.upperPositionLimit[idx_q].copy(),
    )
