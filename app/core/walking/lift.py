"""Lifting a planar configuration to the full robot with the feet and pelvis moved sideways.

The sagittal plan fixes, at every instant, the base's x, z and pitch and the sole placements
(planar forward kinematics of the full model with every non-planar joint at zero). The walk
moves the base sideways by the CoM sway y and the feet to the chosen step width; each leg's
joints (hip yaw/roll/pitch, knee, ankle pitch/roll …: every 1-DOF joint between the base and
the foot that the other leg does not share) then follow from the 6-D pose of the foot relative
to the base, by Gauss–Newton on pinocchio's frame Jacobian, warm-started from the last sample:

    e = log₆(T_base_foot(q)⁻¹ T_base_foot*),   Δq_leg = (J_legᵀ J_leg + λ I)⁻¹ J_legᵀ e.

A leg with fewer than six joints (dircon_biped has no ankle roll) cannot reach every pose: the
least-squares pose leaves a residual, reported as `residual_m_rad`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import pinocchio as pin

from app.core.collocation.planar_model import PlanarModel
from app.core.robot.model import RobotModel

EPS_S = 1e-3
"""Finite-difference step of the walk's velocities and accelerations [s]."""
IK_TOLERANCE = 1e-10
IK_MAX_ITERATIONS = 30
IK_DAMPING = 1e-4
"""Levenberg damping of the Gauss–Newton step [1/rad²]: only matters near singular legs and
unreachable poses, where it keeps the least-squares pose close to the planar solution (at 1e-9
Roban S14's legs jumped branches at the touch-downs of 0.26-leg steps)."""
IK_MAX_STEP_RAD = 0.1
"""Largest joint change of one Gauss–Newton step [rad]. Near a straight knee the damped step
can be hundreds of radians (Roban S14's front leg at the last touch-down of a 0.26-leg step:
its knee went to 12 rad and the walk's speeds to 10⁶ rad/s); a bounded step stays on the
branch the warm start is on."""


class LegLifter:
    """Full configurations from planar ones plus a lateral base offset and a step width."""

    def __init__(self, planar: PlanarModel, step_width_m: float) -> None:
        self.planar = planar
        self.robot: RobotModel = planar.robot
        model = self.robot.model
        self.model, self.data = model, model.createData()
        self.foot_frames = {f.side: self.robot.link_frame_ids[f.link] for f in self.robot.feet}
        chains = {}
        for side, fid in self.foot_frames.items():
            jid, chain = model.frames[fid].parentJoint, []
            while jid > 1:
                chain.append(jid)
                jid = model.parents[jid]
            chains[side] = chain
        shared = set(chains["left"]) & set(chains["right"])
        self.legs = {
            side: [j for j in chain[::-1] if j not in shared and model.joints[j].nq == 1]
            for side, chain in chains.items()
        }
        self.idx_q = {
            s: np.array([model.joints[j].idx_q for j in js]) for s, js in self.legs.items()
        }
        self.idx_v = {
            s: np.array([model.joints[j].idx_v for j in js]) for s, js in self.legs.items()
        }
        q0 = planar.to_full_q(np.zeros(planar.nq))
        pin.framesForwardKinematics(model, self.data, q0)
        natural = {s: float(self.data.oMf[f].translation[1]) for s, f in self.foot_frames.items()}
        self.natural_width_m = natural["left"] - natural["right"]
        """Lateral distance between the feet with every joint at zero [m]."""
        half = 0.5 * (step_width_m - self.natural_width_m)
        self.foot_shift_m = {"left": half, "right": -half}
        self.step_width_m = step_width_m
        self._warm = q0.copy()
        self.residual_m_rad = 0.0
        """Largest foot pose residual of any lift so far (norm of log₆) [m, rad]."""

    def lift(self, q_planar: np.ndarray, y_m: float) -> np.ndarray:
        """The full configuration: base moved by y_m sideways, feet at the step width."""
        model, data = self.model, self.data
        q_flat = self.planar.to_full_q(q_planar)
        pin.framesForwardKinematics(model, data, q_flat)
        base = pin.XYZQUATToSE3(q_flat[:7])
        base.translation = base.translation + np.array([0.0, y_m, 0.0])
        targets = {}
        for side, fid in self.foot_frames.items():
            foot = pin.SE3(data.oMf[fid])
            foot.translation = foot.translation + np.array([0.0, self.foot_shift_m[side], 0.0])
            targets[side] = base.actInv(foot)
        q = self._warm.copy()
        for side in ("left", "right"):  # planar solution: exact at the natural width, no 2π drift
            q[self.idx_q[side]] = q_flat[self.idx_q[side]]
        for side, fid in self.foot_frames.items():
            iq, iv = self.idx_q[side], self.idx_v[side]
            for _ in range(IK_MAX_ITERATIONS):
                pin.framesForwardKinematics(model, data, q)
                error = pin.log6(data.oMf[fid].actInv(targets[side])).vector
                J = pin.computeFrameJacobian(model, data, q, fid, pin.ReferenceFrame.LOCAL)
                Jl = J[:, iv]  # damped least squares: straight knees are singular
                step = np.linalg.solve(Jl.T @ Jl + IK_DAMPING * np.eye(len(iv)), Jl.T @ error)
                step *= min(1.0, IK_MAX_STEP_RAD / max(float(np.abs(step).max()), 1e-300))
                q[iq] += step
                if np.abs(step).max() < IK_TOLERANCE:
                    break
            pin.framesForwardKinematics(model, data, q)
            residual = float(np.linalg.norm(pin.log6(data.oMf[fid].actInv(targets[side])).vector))
            self.residual_m_rad = max(self.residual_m_rad, residual)
        self._warm = q.copy()
        q[:7] = pin.SE3ToXYZQUAT(base)
        return q

    def samples(
        self,
        planar_at: Callable[[int, float], np.ndarray],
        segments: Sequence[tuple[float, float, tuple[bool, bool]]],
        t: np.ndarray,
        which: np.ndarray,
        y: np.ndarray,
        dt: float,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """q, v, a and contacts of the whole-body walk at times `t` [s], sample k in segment
        `which[k]` ((t0, t1, contacts) in `segments`, planar configuration `planar_at(i, t)`),
        the base swayed by `y` [m]; v and a by finite differences of configurations EPS_S
        apart, one-sided at a segment's ends so that no difference crosses a touch-down."""
        yd = np.gradient(y, dt)
        ydd = np.gradient(yd, dt)
        model = self.model
        q = np.empty((len(t), model.nq))
        v = np.empty((len(t), model.nv))
        a = np.empty((len(t), model.nv))
        contacts = np.empty((len(t), 2), dtype=bool)
        for k, tk in enumerate(t):
            t0, t1, contacts[k] = segments[which[k]]
            if tk - EPS_S < t0 - 1e-12:
                offsets = np.array([0.0, 1.0, 2.0]) * EPS_S
            elif tk + EPS_S > t1 + 1e-12:
                offsets = np.array([-2.0, -1.0, 0.0]) * EPS_S
            else:
                offsets = np.array([-1.0, 0.0, 1.0]) * EPS_S
            configs = [
                self.lift(planar_at(int(which[k]), tk + o), y[k] + yd[k] * o + 0.5 * ydd[k] * o * o)
                for o in offsets
            ]
            here = int(np.argmin(np.abs(offsets)))
            q[k] = configs[here]
            d01 = pin.difference(model, configs[0], configs[1]) / EPS_S
            d12 = pin.difference(model, configs[1], configs[2]) / EPS_S
            a[k] = (d12 - d01) / EPS_S
            v[k] = (d01, 0.5 * (d01 + d12), d12)[here] + (here - 1) * 0.5 * EPS_S * a[k]
        return q, v, a, contacts
