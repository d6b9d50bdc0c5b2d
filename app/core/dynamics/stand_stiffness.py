"""Can the robot stand on its servos? The linearised stiffness balance at a standing pose.

A position servo of compliance c is a torsion spring K = 1/c about its set point. Standing on
two flat feet, the pelvis can still move (6 coordinates b: its twist), each leg's joints
following so that both feet stay where they are (leg IK, six joints per leg). The potential
is gravity's plus the servos' springs, V(b) = m·g·z_com(q(b)) + Σ ½ K_j (q_j(b) − q_cmd,j)²,
and the pose is stable when its Hessian

    H = ∇²U + Gᵀ K G − Σ_j τ_j ∂²q_j/∂b²,     G = ∂q/∂b,  U = m·g·z_com

is positive definite. τ are the servos' torques at the pose: the least-norm joint torques
that hold gravity (Gᵀτ = ∇U; symmetric for a symmetric stance). ∇U, ∇²U, G and ∂²q/∂b² are
central differences of the leg IK map (pinocchio). Joints off the legs are held as they are;
the servos' dead bands are left out (gravity keeps them loaded on one side).

The number a user needs is the largest compliance the ankle servos (the two leg joints next
to each foot) may have, the other servos as they are: "needs ≤ X °/(N·m) at the ankles to
stand" (`StandCheck.max_ankle_compliance_deg_per_Nm`). For one body turning about the ankles
this is the textbook balance Σ K_ankle > m·g·h, h the CoM height above the ankle axis;
compliant knees and hips in series lower it.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pinocchio as pin

from app.core.errors import StudioError
from app.core.robot.model import RobotModel

GRAVITY_MPS2 = 9.81
STEP = 1e-4
"""Central-difference step of the pelvis coordinates [m or rad]."""
RIGID_NM_PER_RAD = 1e9
"""Stiffness standing in for a rigid servo (c = 0) [N·m/rad]."""
MAX_COMPLIANCE_DEG_PER_NM = 1e3
"""The search for the ankle limit stops here: an ankle this soft still standing stands on
any servo."""


class StandCheckError(StudioError):
    """The robot does not fit the stiffness balance (not two legs of six joints)."""


@dataclasses.dataclass(frozen=True)
class StandCheck:
    stands: bool
    """H ≻ 0 with the given servos."""
    gravity_Nm_per_rad: float
    """m·g·h [N·m/rad]: gravity's destabilising stiffness about the ankle pitch axes."""
    ankle_Nm_per_rad: float
    """Both ankle pitch servos together, Σ 1/c [N·m/rad] (inf if rigid)."""
    max_ankle_compliance_deg_per_Nm: float | None
    """Largest compliance of the ankle servos that still stands, the others as given
    [°/(N·m)]; inf if any does, None if even rigid ankles do not (other joints too soft)."""
    max_leg_compliance_deg_per_Nm: float | None
    """Largest compliance that stands when every leg servo has it [°/(N·m)] (same
    conventions)."""
    min_eigenvalue: float
    """Smallest eigenvalue of H with the given servos (negative: it falls)."""
    leg_joints: tuple[int, ...] = ()
    """The legs' actuated joints (robot.joints indices), left leg first, foot upwards."""

    def text(self) -> str:
        """One line for the user."""
        limit = self.max_ankle_compliance_deg_per_Nm
        balance = (
            f"gravity m·g·h = {self.gravity_Nm_per_rad:.0f} N·m/rad against "
            f"{self.ankle_Nm_per_rad:.0f} N·m/rad from the ankle servos"
        )
        if limit is None:
            return (
                f"cannot stand even on rigid ankles: the other leg servos are too soft ({balance})"
            )
        if math.isinf(limit):
            return f"stands on any ankle servo ({balance})"
        head = "stands" if self.stands else "cannot stand"
        return f"{head}: needs ≤ {limit:.2f} °/(N·m) at the ankles to stand ({balance})"


class _Legs:
    """The leg IK map b ↦ q(b): pelvis twist b (6,), legs solved to keep both feet placed."""

    def __init__(self, robot: RobotModel, q: np.ndarray) -> None:
        if not robot.floating_base or len(robot.feet) != 2:
            raise StandCheckError(f"{robot.name} does not stand on two feet")
        self.robot, self.q0 = robot, np.array(q, dtype=float)
        model = robot.model
        self.data = model.createData()
        chains = [self._chain(foot.link) for foot in robot.feet]
        common = set(chains[0]) & set(chains[1])
        self.legs = [[j for j in chain if j not in common] for chain in chains]
        if any(len(leg) != 6 for leg in self.legs):
            raise StandCheckError(
                f"{robot.name}'s legs have {[len(leg) for leg in self.legs]} joints; the "
                "stand check needs six per leg"
            )
        self.frames = [robot.link_frame_ids[foot.link] for foot in robot.feet]
        pin.framesForwardKinematics(model, self.data, self.q0)
        self.targets = [self.data.oMf[f].copy() for f in self.frames]
        self.joints = [j for leg in self.legs for j in leg]
        self.idx_q = np.array([robot.joints[j].idx_q for j in self.joints])
        self.idx_v = [[robot.joints[j].idx_v for j in leg] for leg in self.legs]

    def _chain(self, foot_link: str) -> list[int]:
        """Actuated joints (robot.joints indices) from the foot up to the root."""
        model = self.robot.model
        index = {model.getJointId(j.name): i for i, j in enumerate(self.robot.joints)}
        jid, out = model.frames[self.robot.link_frame_ids[foot_link]].parentJoint, []
        while jid > 0:
            if jid in index:
                out.append(index[jid])
            jid = model.parents[jid]
        return out

    def q(self, b: np.ndarray) -> np.ndarray:
        model, data = self.robot.model, self.data
        q = self.q0.copy()
        twist = np.zeros(model.nv)
        twist[:6] = b
        q = pin.integrate(model, q, twist)
        for _ in range(20):
            pin.framesForwardKinematics(model, data, q)
            errors = [
                pin.log6(data.oMf[f].actInv(t)).vector
                for f, t in zip(self.frames, self.targets, strict=True)
            ]
            if max(float(np.abs(e).max()) for e in errors) < 1e-13:
                break
            pin.computeJointJacobians(model, data, q)
            dv = np.zeros(model.nv)
            for frame, error, cols in zip(self.frames, errors, self.idx_v, strict=True):
                J = pin.getFrameJacobian(model, data, frame, pin.LOCAL)[:, cols]
                dv[cols] = np.linalg.solve(J, error)
            q = pin.integrate(model, q, dv)
        return q


def stand_check(robot: RobotModel, q: np.ndarray, compliance_deg_per_Nm: np.ndarray) -> StandCheck:
    """The stiffness balance (module docstring) at the standing pose q (both feet flat on the
    floor) with the servos' compliance [°/(N·m)] per actuated joint (robot.joints order;
    0 = rigid). StandCheckError where the legs do not fit, or are straight (the leg IK is
    singular there: the balance needs bent knees)."""
    try:
        return _stand_check(robot, q, compliance_deg_per_Nm)
    except np.linalg.LinAlgError as error:
        raise StandCheckError(
            f"the legs are singular at this pose ({error}): straight knees have no balance to "
            "linearise; bend them (the ready pose) first"
        ) from error


def _stand_check(robot: RobotModel, q: np.ndarray, compliance_deg_per_Nm: np.ndarray) -> StandCheck:
    legs = _Legs(robot, q)
    model = robot.model
    weight = robot.mass_kg * GRAVITY_MPS2
    com_data = model.createData()
    h = STEP
    samples: dict[tuple[int, int, int, int], tuple[float, np.ndarray]] = {}

    def at(i: int, si: int, j: int, sj: int) -> tuple[float, np.ndarray]:
        key = (i, si, j, sj)
        if key not in samples:
            b = np.zeros(6)
            if i >= 0:
                b[i] += si * h
            if j >= 0:
                b[j] += sj * h
            q_b = legs.q(b)
            samples[key] = (
                weight * float(pin.centerOfMass(model, com_data, q_b)[2]),
                q_b[legs.idx_q],
            )
        return samples[key]

    U0, q0 = at(-1, 0, -1, 0)
    grad_U, G = np.zeros(6), np.zeros((len(q0), 6))
    hess_U, hess_q = np.zeros((6, 6)), np.zeros((len(q0), 6, 6))
    for i in range(6):
        (Up, qp), (Um, qm) = at(i, 1, -1, 0), at(i, -1, -1, 0)
        grad_U[i], G[:, i] = (Up - Um) / (2 * h), (qp - qm) / (2 * h)
        hess_U[i, i], hess_q[:, i, i] = (Up - 2 * U0 + Um) / h**2, (qp - 2 * q0 + qm) / h**2
        for j in range(i + 1, 6):
            (a, qa), (b_, qb) = at(i, 1, j, 1), at(i, 1, j, -1)
            (c, qc), (d, qd) = at(i, -1, j, 1), at(i, -1, j, -1)
            hess_U[i, j] = hess_U[j, i] = (a - b_ - c + d) / (4 * h * h)
            hess_q[:, i, j] = hess_q[:, j, i] = (qa - qb - qc + qd) / (4 * h * h)
    tau = np.linalg.lstsq(G.T, grad_U, rcond=None)[0]  # least-norm torques holding gravity
    geometric = hess_U - np.einsum("j,jab->ab", tau, hess_q)
    compliance = np.radians(np.asarray(compliance_deg_per_Nm, dtype=float))[legs.joints]
    ankles = np.array([k < 2 or 6 <= k < 8 for k in range(12)])  # two joints next to each foot

    def min_eig(c: np.ndarray) -> float:
        K = np.where(c > 0.0, 1.0 / np.maximum(c, 1e-300), RIGID_NM_PER_RAD)
        return float(np.linalg.eigvalsh(G.T @ (K[:, None] * G) + geometric).min())

    given = min_eig(compliance)
    return StandCheck(
        stands=given > 0.0,
        gravity_Nm_per_rad=_gravity_about_ankles(robot, legs, weight),
        ankle_Nm_per_rad=_ankle_pitch_stiffness(robot, legs, compliance),
        max_ankle_compliance_deg_per_Nm=_limit(lambda c: min_eig(np.where(ankles, c, compliance))),
        max_leg_compliance_deg_per_Nm=_limit(lambda c: min_eig(np.full(12, c))),
        min_eigenvalue=given,
        leg_joints=tuple(int(j) for j in legs.joints),
    )


def _limit(min_eig) -> float | None:
    """The largest compliance c [°/(N·m)] with min_eig(c [rad/(N·m)]) > 0 (bisection; H only
    stiffens as c falls): inf if the search's top stands, None if rigid servos do not."""
    top = math.radians(MAX_COMPLIANCE_DEG_PER_NM)
    if min_eig(0.0) <= 0.0:
        return None
    if min_eig(top) > 0.0:
        return math.inf
    low, high = 0.0, top  # stands at low, falls at high
    for _ in range(60):
        middle = 0.5 * (low + high)
        low, high = (middle, high) if min_eig(middle) > 0.0 else (low, middle)
    return math.degrees(low)


def _pitch_ankles(robot: RobotModel, legs: _Legs) -> list[int]:
    """Per leg, the position (0 or 1) in legs.joints' leg block of the ankle joint whose axis
    is nearest the world's y axis (pitch)."""
    data = legs.data
    pin.forwardKinematics(robot.model, data, legs.q0)
    out = []
    for leg in legs.legs:
        scores = []
        for j in leg[:2]:
            jid = robot.model.getJointId(robot.joints[j].name)
            J = pin.getJointJacobian(robot.model, data, jid, pin.LOCAL_WORLD_ALIGNED)
            axis = J[3:, robot.joints[j].idx_v]
            scores.append(abs(axis[1]) / max(float(np.linalg.norm(axis)), 1e-12))
        out.append(int(np.argmax(scores)))
    return out


def _gravity_about_ankles(robot: RobotModel, legs: _Legs, weight: float) -> float:
    """m·g·h, h the CoM's height above the ankle pitch joints (mean of the legs) [N·m/rad]."""
    data = legs.data
    pin.forwardKinematics(robot.model, data, legs.q0)
    heights = [
        data.oMi[robot.model.getJointId(robot.joints[leg[k]].name)].translation[2]
        for leg, k in zip(legs.legs, _pitch_ankles(robot, legs), strict=True)
    ]
    com = pin.centerOfMass(robot.model, robot.model.createData(), legs.q0)
    return weight * float(com[2] - np.mean(heights))


def _ankle_pitch_stiffness(robot: RobotModel, legs: _Legs, compliance: np.ndarray) -> float:
    total = 0.0
    for block, k in enumerate(_pitch_ankles(robot, legs)):
        c = float(compliance[6 * block + k])
        total += math.inf if c <= 0.0 else 1.0 / c
    return total
