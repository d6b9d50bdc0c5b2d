"""The sagittal (x-z plane) rigid-body model of a biped, as casadi SX functions.

The gait paper plans in the plane: a floating base with coordinates x, z [m] and pitch [rad]
(world frame), and per leg the three pitch joints (hip pitch, knee, ankle); hip roll and yaw are
held at zero. planar_reduction.py reduces the pinocchio model to that plane (locked joints'
bodies merged, inertias projected); the reduction is exact for planar motions:
M_planar = Gᵀ M_full G  and  h_planar = Gᵀ (M_full Ġ v + h_full), with G the map from planar to
full velocities (`velocity_map`).

Planar coordinates q = [x, z, pitch, planar joints in pinocchio order], v = q̇ (base x, z rates
in the world frame), so v has the same layout. Rotation convention is pinocchio's R_y(θ): a
body point (x_b, z_b) is at (cos θ·x_b + sin θ·z_b, −sin θ·x_b + cos θ·z_b) in its parent.

Dynamics are by a recursive Newton–Euler pass in world coordinates (`rnea`), with gravity as an
upward acceleration of the world; M(q) is the Jacobian of the gravity-free RNEA in a.
The contact points are the mid-points of the rear (heel) and front (toe) sole edges.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np
import pinocchio as pin

from app.core.collocation.hip_group import HipGroup, make_hip_group
from app.core.collocation.planar_reduction import (
    BASE_DOF,
    PlanarModelError,
    reduce_to_plane,
    world_axes,
)
from app.core.robot.model import RobotModel

__all__ = ["BASE_DOF", "CONTACT_NAMES", "PlanarModel", "PlanarModelError", "evaluate"]

EXCHANGE_SLACK = 5.0
"""Exchange tolerance per radian of leg asymmetry (see PlanarModel.exchange_tolerance)."""
CONTACT_NAMES = ("left_heel", "left_toe", "right_heel", "right_toe")
"""Order of the four contact points in `contact_positions` and `contact_jacobian` (x, z each)."""


def _rot(theta: Any) -> tuple[Any, Any]:
    return ca.cos(theta), ca.sin(theta)


def _apply(theta: Any, xz: Any) -> tuple[Any, Any]:
    """R_y(θ) applied to a vector (x, z)."""
    c, s = _rot(theta)
    return c * xz[0] + s * xz[1], -s * xz[0] + c * xz[1]


def _cross_w(omega: Any, r: tuple[Any, Any]) -> tuple[Any, Any]:
    """ω ŷ × r for r in the x-z plane."""
    return omega * r[1], -omega * r[0]


def _moment(r: tuple[Any, Any], f: tuple[Any, Any]) -> Any:
    """(r × f)·ŷ for r, f in the x-z plane."""
    return r[1] * f[0] - r[0] * f[1]


class PlanarModel:
    """The planar reduction of a floating-base biped, with casadi functions of (q, v, a).

    Functions (casadi, SX inside; call with numbers or symbols):
      rnea(q, v, a) -> τ (nv)             generalised forces, gravity included
      mass_matrix(q) -> M (nv × nv)
      bias(q, v) -> h (nv)                Coriolis, centrifugal and gravity: rnea(q, v, 0)
      contact_positions(q) -> p (8)       (x, z) of left heel, left toe, right heel, right toe
      contact_jacobian(q) -> J (8 × nv)
      contact_jdot_v(q, v) -> J̇v (8)
      com(q) -> (x, z) (2)                whole-body centre of mass
    """

    def __init__(self, robot: RobotModel, planar_joints: tuple[str, ...] | None = None) -> None:
        model = robot.model
        tree = reduce_to_plane(robot, planar_joints)
        self.robot = robot
        self.gravity = float(-model.gravity.linear[2])
        self.joint_names = tree.joint_names
        self.bodies = tree.bodies
        self.contact_points = tree.contact_points
        self.leg_joints = tree.leg_joints
        self.nq = self.nv = BASE_DOF + len(self.joint_names)
        self.nu = len(self.joint_names)
        axes, _ = world_axes(model)
        self.hip_groups: dict[int, HipGroup] = {
            self.joint_names.index(name): make_hip_group(model, group, axes)
            for name, group in tree.hip_groups.items()
        }
        """Virtual hip pitch joints by planar joint index (Roban S14; see hip_group.py)."""
        self._hip_start: dict[int, np.ndarray] = {}
        ids = [
            tree.hip_groups[name][0] if name in tree.hip_groups else model.getJointId(name)
            for name in self.joint_names
        ]
        self.joint_idx_q = np.array([model.joints[i].idx_q for i in ids])
        """q index of each planar joint (a hip group's first joint for a virtual joint)."""
        self.joint_idx_v = np.array([model.joints[i].idx_v for i in ids])
        self.mass_kg = float(sum(b.mass_kg for b in self.bodies))
        self.lower = model.lowerPositionLimit[self.joint_idx_q].copy()
        """Joint position limits [rad] (Table 1 for dircon_biped), shape (nu,); a virtual hip
        joint's range is where its group's joints stay within their limits."""
        self.upper = model.upperPositionLimit[self.joint_idx_q].copy()
        self.effort_Nm = model.effortLimit[self.joint_idx_v].copy()
        """URDF effort limits of the planar joints [N·m] (0 where the URDF gives none; a
        virtual hip joint takes its group's smallest)."""
        self.velocity_radps = model.velocityLimit[self.joint_idx_v].copy()
        """URDF velocity limits of the planar joints [rad/s] (0 where the URDF gives none)."""
        for k, group in self.hip_groups.items():
            self.lower[k], self.upper[k] = group.pitch_range()
            self.effort_Nm[k] = model.effortLimit[group.idx_v].min()
            self.velocity_radps[k] = model.velocityLimit[group.idx_v].min()
        self._build_functions()
        self._mapped_points: dict[int, ca.Function] = {}
        """contact_positions mapped over n configurations, by n (contact_positions_at)."""
        self.standing_height_m = -float(
            evaluate(self.contact_positions, np.zeros(self.nq))[1::2].min()
        )
        """Base height above the soles with every joint at zero (straight legs) [m]."""
        self.leg_asymmetry_m = self._leg_asymmetry()
        """Largest difference between the legs' joint offsets, CoMs and sole points [m]."""
        self.exchange_tolerance = EXCHANGE_SLACK * self.leg_asymmetry_m / self.standing_height_m
        """Tolerance of eq. 6's joint-state exchange [rad, rad/s]: 0 for mirror-identical legs.
        Legs that differ (SigmaBan's by 0.24 mm) cannot exchange their states exactly with both
        soles flat on the floor, so the exchange holds to a few times the angle that the
        difference subtends on the leg."""

    # -- kinematics and dynamics ---------------------------------------------------------------

    def _forward(self, q: Any, v: Any, a: Any, gravity: float) -> list[dict[str, Any]]:
        """Pose, velocity and acceleration of every body's joint origin (world frame)."""
        states: list[dict[str, Any]] = []
        for i, body in enumerate(self.bodies):
            if i == 0:
                s = {
                    "theta": q[2], "omega": v[2], "alpha": a[2],
                    "o": (q[0], q[1]), "vo": (v[0], v[1]), "ao": (a[0], a[1] + gravity),
                }  # fmt: skip
            else:
                p = states[body.parent]
                k = BASE_DOF + i - 1
                r = _apply(p["theta"], body.joint_xz_m)
                wr = _cross_w(p["omega"], r)
                ar = _cross_w(p["alpha"], r)
                sign = body.axis_sign
                s = {
                    "theta": p["theta"] + body.joint_pitch_rad + sign * q[k],
                    "omega": p["omega"] + sign * v[k],
                    "alpha": p["alpha"] + sign * a[k],
                    "o": (p["o"][0] + r[0], p["o"][1] + r[1]),
                    "vo": (p["vo"][0] + wr[0], p["vo"][1] + wr[1]),
                    "ao": (
                        p["ao"][0] + ar[0] - p["omega"] ** 2 * r[0],
                        p["ao"][1] + ar[1] - p["omega"] ** 2 * r[1],
                    ),
                }
            states.append(s)
        return states

    def _rnea(self, q: Any, v: Any, a: Any, gravity: float) -> Any:
        """Recursive Newton–Euler: forward pass for accelerations, backward pass for forces."""
        states = self._forward(q, v, a, gravity)
        force: list[Any] = [None] * len(self.bodies)
        moment: list[Any] = [None] * len(self.bodies)
        for i in reversed(range(len(self.bodies))):
            body, s = self.bodies[i], states[i]
            c = _apply(s["theta"], body.com_xz_m)
            wc = _cross_w(s["alpha"], c)
            ac = (
                s["ao"][0] + wc[0] - s["omega"] ** 2 * c[0],
                s["ao"][1] + wc[1] - s["omega"] ** 2 * c[1],
            )
            f = (body.mass_kg * ac[0], body.mass_kg * ac[1])
            n = body.inertia_yy * s["alpha"] + _moment(c, f)
            for j, child in enumerate(self.bodies):
                if child.parent == i:
                    r = (states[j]["o"][0] - s["o"][0], states[j]["o"][1] - s["o"][1])
                    f = (f[0] + force[j][0], f[1] + force[j][1])
                    n = n + moment[j] + _moment(r, force[j])
            force[i], moment[i] = f, n
        joint_moments = [b.axis_sign * n for b, n in zip(self.bodies[1:], moment[1:], strict=True)]
        return ca.vertcat(force[0][0], force[0][1], moment[0], *joint_moments)

    def _points(self, q: Any) -> Any:
        zero = [0.0] * self.nv
        states = self._forward(q, zero, zero, 0.0)
        coords = []
        for body, xz in self.contact_points:
            r = _apply(states[body]["theta"], xz)
            coords += [states[body]["o"][0] + r[0], states[body]["o"][1] + r[1]]
        return ca.vertcat(*coords)

    def _com(self, q: Any) -> Any:
        """Whole-body CoM (x, z) [m]."""
        zero = [0.0] * self.nv
        states = self._forward(q, zero, zero, 0.0)
        x = z = 0.0
        for body, s in zip(self.bodies, states, strict=True):
            c = _apply(s["theta"], body.com_xz_m)
            x = x + body.mass_kg * (s["o"][0] + c[0])
            z = z + body.mass_kg * (s["o"][1] + c[1])
        return ca.vertcat(x, z) / self.mass_kg

    def _build_functions(self) -> None:
        q = ca.SX.sym("q", self.nq)
        v = ca.SX.sym("v", self.nv)
        a = ca.SX.sym("a", self.nv)
        tau = self._rnea(q, v, a, self.gravity)
        mass = ca.jacobian(self._rnea(q, ca.SX.zeros(self.nv), a, 0.0), a)
        points = self._points(q)
        jac = ca.jacobian(points, q)
        jdot_v = ca.jacobian(jac @ v, q) @ v
        self.rnea = ca.Function("rnea", [q, v, a], [tau], ["q", "v", "a"], ["tau"])
        self.mass_matrix = ca.Function("mass_matrix", [q], [ca.simplify(mass)], ["q"], ["M"])
        self.bias = ca.Function(
            "bias", [q, v], [ca.substitute(tau, a, ca.SX.zeros(self.nv))], ["q", "v"], ["h"]
        )
        self.contact_positions = ca.Function("contact_positions", [q], [points], ["q"], ["p"])
        self.com = ca.Function("com", [q], [self._com(q)], ["q"], ["com"])
        self.contact_jacobian = ca.Function("contact_jacobian", [q], [jac], ["q"], ["J"])
        self.contact_jdot_v = ca.Function("contact_jdot_v", [q, v], [jdot_v], ["q", "v"], ["Jdv"])

    def contact_positions_at(self, qs: np.ndarray) -> np.ndarray:
        """contact_positions at each row of `qs` (T, nq), as (8, T); the mapped casadi function
        of T columns is built once per T and kept (a gait's readout asks for the same T at every
        solve)."""
        n = len(qs)
        if n not in self._mapped_points:
            self._mapped_points[n] = self.contact_positions.map(n)
        return np.array(self._mapped_points[n](qs.T).full()).reshape(8, n)

    def _leg_asymmetry(self) -> float:
        left, right = (self.leg_joints[s] - BASE_DOF + 1 for s in ("left", "right"))
        gaps = [0.0]
        for i, j in zip(left, right, strict=True):
            one, two = self.bodies[i], self.bodies[j]
            gaps += [
                float(np.abs(one.joint_xz_m - two.joint_xz_m).max()),
                float(np.abs(one.com_xz_m - two.com_xz_m).max()),
            ]
        points = [xz for _, xz in self.contact_points]
        gaps += [
            float(np.abs(points[0] - points[2]).max()),
            float(np.abs(points[1] - points[3]).max()),
        ]
        return max(gaps)

    # -- planar <-> full pinocchio configuration -------------------------------------------------

    def to_full_q(self, q: np.ndarray) -> np.ndarray:
        """Full pinocchio configuration(s) of planar q (…, nq): y = 0, locked joints at their
        neutral value (0)."""
        q = np.asarray(q, dtype=float)
        out = np.zeros((*q.shape[:-1], self.robot.model.nq))
        out[...] = pin.neutral(self.robot.model)
        out[..., 0] = q[..., 0]
        out[..., 2] = q[..., 1]
        out[..., 4] = np.sin(0.5 * q[..., 2])  # quaternion xyzw about y
        out[..., 6] = np.cos(0.5 * q[..., 2])
        out[..., self.joint_idx_q] = q[..., BASE_DOF:]
        for k, group in self.hip_groups.items():
            flat_in, flat_out = q.reshape(-1, self.nq), out.reshape(-1, out.shape[-1])
            for row_in, row_out in zip(flat_in, flat_out, strict=True):
                theta = group.angles(row_in[BASE_DOF + k], self._hip_start.get(k))
                self._hip_start[k] = theta  # Newton from the last solution: 2–3 iterations
                row_out[group.idx_q] = theta
        return out

    def from_full_q(self, q_full: np.ndarray) -> np.ndarray:
        """Planar q of a full configuration (lateral and out-of-plane parts dropped)."""
        q_full = np.asarray(q_full, dtype=float)
        qx, qy, qz, qw = (q_full[..., 3 + i] for i in range(4))
        r00 = 1.0 - 2.0 * (qy * qy + qz * qz)
        r02 = 2.0 * (qx * qz + qy * qw)
        out = np.empty((*q_full.shape[:-1], self.nq))
        out[..., 0] = q_full[..., 0]
        out[..., 1] = q_full[..., 2]
        out[..., 2] = np.arctan2(r02, r00)
        out[..., BASE_DOF:] = q_full[..., self.joint_idx_q]
        for k, group in self.hip_groups.items():
            flat_in, flat_out = q_full.reshape(-1, q_full.shape[-1]), out.reshape(-1, self.nq)
            for row_in, row_out in zip(flat_in, flat_out, strict=True):
                row_out[BASE_DOF + k] = group.pitch(row_in[group.idx_q])
        return out

    def velocity_map(self, q: np.ndarray) -> np.ndarray:
        """G(q), (nv_full × nv): full velocity = G · planar velocity.

        Pinocchio's free-flyer velocity is the base twist in the base frame:
        v_lin = R_y(θ)ᵀ (ẋ, 0, ż), ω = (0, θ̇, 0)."""
        G = np.zeros((self.robot.model.nv, self.nv))
        c, s = np.cos(q[2]), np.sin(q[2])
        G[0, 0], G[0, 1] = c, -s  # R_y(θ)ᵀ rows x and z
        G[2, 0], G[2, 1] = s, c
        G[4, 2] = 1.0
        G[self.joint_idx_v, np.arange(BASE_DOF, self.nv)] = 1.0
        for k, group in self.hip_groups.items():
            G[group.idx_v, BASE_DOF + k] = group.rates(q[BASE_DOF + k])
        return G

    def to_full_v(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Full generalised velocity of a planar state."""
        return self.velocity_map(q) @ v

    def to_full_a(self, q: np.ndarray, v: np.ndarray, a: np.ndarray) -> np.ndarray:
        """Full generalised acceleration: G a + Ġ v, Ġ v = −ω × v_lin (pinocchio's base-frame
        spatial acceleration is the time derivative of the base-frame twist)."""
        out = self.velocity_map(q) @ a
        vf = self.velocity_map(q) @ v
        omega = v[2]
        out[0] -= omega * vf[2]  # (ω ŷ × v)_x = ω v_z
        out[2] += omega * vf[0]  # (ω ŷ × v)_z = −ω v_x
        for k, group in self.hip_groups.items():  # d/dt (θ̇/α̇) α̇ by central differences in α
            alpha, rate, h = q[BASE_DOF + k], v[BASE_DOF + k], 1e-5
            curvature = (group.rates(alpha + h) - group.rates(alpha - h)) / (2 * h)
            out[group.idx_v] += curvature * rate * rate
        return out


def evaluate(function: ca.Function, *args: np.ndarray) -> np.ndarray:
    """A casadi function's first output at numeric inputs, as a numpy array (squeezed vector)."""
    out = np.array(function(*args).full())
    return out[:, 0] if out.shape[1] == 1 else out
