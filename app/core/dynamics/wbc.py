"""Torque feed-forward τ(t) of a planned motion: CoM LQR + whole-body QP, friction pyramids.

The spring-compensation paper (Wang et al. 2023, Secs. 3–4) gets the joint torques its spring
compensation q_des = q + k·τ (eq. 7) needs from a whole-body QP (eqs. 12–18) over the joint
accelerations q̈ and the contact forces at the four corners of each rectangular sole, whose
cost contains the value function V of a CoM LQR (eqs. 1–5). τ then follows from eq. 10. The
QP itself is in app.core.dynamics.wbc_qp (made small in wbc_reduced); this module checks
inputs, runs it over chunks of samples (app.core.dynamics.wbc_chunks; the parameters in
wbc_params) and returns a FeedForward. With the reduced QP a chunk is solved in bulk: one
pinocchio pass per sample, the closed form (no inequality active) for all samples of a
contact state at once, DAQP for the others.

Feed-forward means the state is the plan's own: x̄ = x − x^d = 0 unless a CoM state error is
given, so V reduces to ūᵀ(R + a²Q_p)ū, a cost on leaving the plan's CoM acceleration.

A sample is "solved" when the QP's accelerations stay within `max_qdd_error` of the plan's and
its torques within their limits: τ then realises the planned motion with contact forces inside
the friction pyramids (the dynamics hold to round-off, whatever the QP solver's tolerance). Otherwise
the status says why, and the run goes on:
- "cannot follow the plan: …" (CoM outside the stance sole, too little friction, a torque
  limit): τ, forces and q̈ are those of the QP's nearest realisable motion;
- "no solution: …" (the QP is infeasible): τ, forces and q̈ are copied from the nearest
  sample that has a solution, and the status names it. We hold rather than write NaN so that
  a torque file stays usable downstream (compensation, plots) with its status column saying
  which rows are stand-ins; only if no sample has a solution are the values NaN.
`infeasible_samples` lists every sample that is not "solved".
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Protocol

import numpy as np

from app.core.dynamics.wbc_chunks import (
    CHUNK_SAMPLES,
    TORQUE_TOLERANCE,
    ChunkInput,
    ChunkResult,
    chunk_bounds,
    make_qp,
    solve_chunk,
    stack_results,
)
from app.core.dynamics.wbc_params import WbcError, WbcParams, torque_limits
from app.core.dynamics.wbc_qp import N_CORNERS, QpSolver
from app.core.motions.trajectory import Trajectory
from app.core.robot.model import RobotModel

__all__ = [
    "CHUNK_SAMPLES",
    "TORQUE_TOLERANCE",
    "ChunkInput",
    "ChunkResult",
    "ChunkRunner",
    "FeedForward",
    "WbcError",
    "WbcParams",
    "chunk_bounds",
    "make_qp",
    "solve_chunk",
    "stack_results",
    "torque_feedforward",
    "torque_limits",
]

MAX_SPEED = 1e3
"""Largest |v| accepted in a trajectory [rad/s or m/s]; more is taken as corrupt input."""
MAX_ACCELERATION = 1e5
"""Largest |a| accepted in a trajectory [rad/s² or m/s²]."""


@dataclasses.dataclass(frozen=True)
class FeedForward:
    """Joint torques and contact forces that realise a trajectory, one row per sample."""

    trajectory_name: str
    joint_names: tuple[str, ...]
    """Actuated joints, the robot's order: the columns of tau_Nm."""
    t: np.ndarray
    """Sample times [s], shape (T,)."""
    tau_Nm: np.ndarray
    """Actuated joint torques of eq. 10 [N·m, N for a prismatic joint], shape (T, n_actuated).
    Samples without a QP solution hold the nearest solved sample's values (see `status`)."""
    contact_forces_N: np.ndarray
    """Force of the ground on each sole corner, world frame [N], shape (T, 2, 4, 3):
    (left, right), corner in Foot.sole_corners_m order, xyz. Zero for a foot in the air."""
    qdd: np.ndarray
    """Generalised accelerations the torques realise, shape (T, nv) (pinocchio's layout)."""
    loop_forces_N: np.ndarray
    """Internal force of each declared closed loop (robot.tree.loops order) on its link_a
    side, world frame [N], shape (T, n_loops, 3); link_b gets the opposite force."""
    status: tuple[str, ...]
    """Per sample: "solved", or what went wrong in words."""
    qp_time_s: np.ndarray
    """Wall time of building and solving each sample's QP [s], shape (T,). With the reduced
    QP, whose samples are solved in bulk: the sample's own pinocchio pass and DAQP solve plus
    an equal share of the batched work."""
    tau_units: tuple[str, ...]
    """Unit of each column of tau_Nm: "N·m", or "N" for a prismatic joint."""
    notes: tuple[str, ...] = ()
    """Remarks about the whole run (e.g. joints without torque limits)."""
    solver_time_s: np.ndarray | None = None
    """Wall time of the QP solver's own call in each sample [s], shape (T,) (within
    qp_time_s: the rest is kinematics and assembly)."""

    @property
    def infeasible_samples(self) -> np.ndarray:
        """Indices of the samples whose status is not "solved", shape (n,), int."""
        return np.array([k for k, s in enumerate(self.status) if s != "solved"], dtype=int)


def torque_feedforward(
    robot: RobotModel,
    trajectory: Trajectory,
    params: WbcParams = WbcParams(),  # noqa: B008 - frozen, checked on construction
    progress: Callable[[float], None] | None = None,
    com_state_error: np.ndarray | None = None,
    *,
    pool: ChunkRunner | None = None,
    solver: QpSolver = "reduced",
) -> FeedForward:
    """Solve the whole-body QP at every sample of a trajectory; never fails on a sample.

    Contacts come from `trajectory.contacts`; the plan's q̈ is `trajectory.a`. `progress` is
    called with the fraction done (0…1) after each chunk and may raise to cancel.
    `com_state_error` (T, 6) is x̄ = x − x^d [m, m/s] for the CoM LQR term, e.g. a measured
    CoM state minus the plan's; None is the feed-forward case x̄ = 0.

    The samples are solved in chunks of CHUNK_SAMPLES contiguous samples, each warm-started
    along itself from a cold first sample, so a chunk's answer does not depend on where it
    runs: `pool` (app.core.dynamics.parallel.FeedForwardPool) spreads them over worker
    processes and gives bit-identical results to solving them here one after the other.
    Raises WbcError for input that does not fit the robot (joints, shapes, NaN, absurd values).
    """
    x_bar = _check_inputs(robot, trajectory, com_state_error)
    _bound, unbounded = torque_limits(robot, params)
    n = trajectory.n_samples
    chunks = [
        ChunkInput(
            trajectory.q[s:e],
            trajectory.v[s:e],
            trajectory.a[s:e],
            trajectory.contacts[s:e],
            x_bar[s:e],
        )
        for s, e in chunk_bounds(n)
    ]
    if pool is not None:
        results = pool.map_chunks(robot, params, solver, chunks, progress)
    else:
        qp = make_qp(robot, params, solver)
        results = []
        for k, chunk in enumerate(chunks):
            if progress is not None:
                progress(k / len(chunks))
            results.append(solve_chunk(qp, chunk, params))
    if progress is not None:
        progress(1.0)
    tau = np.concatenate([r.tau for r in results]) if results else np.zeros((0, robot.n_actuated))
    forces = (
        np.concatenate([r.forces for r in results]) if results else np.zeros((0, 2, N_CORNERS, 3))
    )
    qdd = np.concatenate([r.qdd for r in results]) if results else np.zeros((0, robot.model.nv))
    loop_forces = (
        np.concatenate([r.loop_forces for r in results])
        if results
        else np.zeros((0, len(robot.tree.loops), 3))
    )
    times = np.concatenate([r.times for r in results]) if results else np.zeros(0)
    solver_times = np.concatenate([r.solver_times for r in results]) if results else np.zeros(0)
    solved = np.concatenate([r.solved for r in results]) if results else np.zeros(0, bool)
    status: list[str] = [text for r in results for text in r.status]
    if solved.any():
        for k in np.flatnonzero(~solved):
            source = _nearest(solved, k)
            for array in (tau, forces, qdd, loop_forces):
                array[k] = array[source]
            status[k] += f"; values held from sample {source} (t = {trajectory.t[source]:.3f} s)"
    notes = []
    if unbounded:
        notes.append(f"no torque limit (unbounded): {', '.join(unbounded)}")
    for foot in robot.feet:
        corners = np.asarray(foot.sole_corners_m, dtype=float)
        if np.ptp(corners, axis=0).max() < 1e-6:
            notes.append(f"{foot.link} has no sole geometry: its contact is a single point")
    return FeedForward(
        trajectory_name=trajectory.name,
        joint_names=robot.joint_names,
        t=trajectory.t.copy(),
        tau_Nm=tau,
        contact_forces_N=forces,
        qdd=qdd,
        loop_forces_N=loop_forces,
        status=tuple(status),
        qp_time_s=times,
        tau_units=tuple("N" if j.kind == "prismatic" else "N·m" for j in robot.joints),
        notes=tuple(notes),
        solver_time_s=solver_times,
    )


class ChunkRunner(Protocol):
    """Solves chunks elsewhere (worker processes), in order, exactly as `solve_chunk` here;
    returns their results in order, consecutive chunks possibly stacked into one result."""

    def map_chunks(
        self,
        robot: RobotModel,
        params: WbcParams,
        solver: QpSolver,
        chunks: list[ChunkInput],
        progress: Callable[[float], None] | None,
    ) -> list[ChunkResult]: ...


def _nearest(solved: np.ndarray, k: int) -> int:
    """Index of the solved sample nearest to k (the earlier one on a tie)."""
    indices = np.flatnonzero(solved)
    return int(indices[np.argmin(np.abs(indices - k))])


def _check_inputs(
    robot: RobotModel, trajectory: Trajectory, com_state_error: np.ndarray | None
) -> np.ndarray:
    """x̄ per sample, shape (T, 6), after checking that the trajectory fits the robot."""
    if not robot.floating_base:
        raise WbcError(
            f"{robot.name!r} is fixed to the world: torque feed-forward with foot contacts "
            "needs a floating-base biped"
        )
    if tuple(trajectory.joint_names) != robot.joint_names:
        missing = [j for j in robot.joint_names if j not in trajectory.joint_names]
        extra = [j for j in trajectory.joint_names if j not in robot.joint_names]
        detail = (
            f"missing {missing}, unknown {extra}" if missing or extra else "in a different order"
        )
        raise WbcError(
            f"trajectory {trajectory.name!r} does not fit robot {robot.name!r}: joints {detail}"
        )
    model, n = robot.model, trajectory.n_samples
    shapes = {"q": (n, model.nq), "v": (n, model.nv), "a": (n, model.nv), "contacts": (n, 2)}
    for label, shape in shapes.items():
        array = np.asarray(getattr(trajectory, label))
        if array.shape != shape:
            raise WbcError(
                f"trajectory {trajectory.name!r}: {label} has shape {array.shape}, "
                f"robot {robot.name!r} needs {shape}"
            )
    for label, limit in (("q", MAX_SPEED), ("v", MAX_SPEED), ("a", MAX_ACCELERATION)):
        array = getattr(trajectory, label)
        if not np.all(np.isfinite(array)):
            raise WbcError(f"trajectory {trajectory.name!r}: {label} contains NaN or inf")
        worst = float(np.abs(array).max())
        if worst > limit:
            raise WbcError(
                f"trajectory {trajectory.name!r}: |{label}| reaches {worst:.3g}, over {limit:g}; "
                "check the units (rad, m, s)"
            )
    norms = np.linalg.norm(trajectory.q[:, 3:7], axis=1)
    if np.abs(norms - 1.0).max() > 1e-3:
        raise WbcError(
            f"trajectory {trajectory.name!r}: base quaternions are not unit (norm "
            f"{norms[np.argmax(np.abs(norms - 1.0))]:.4g})"
        )
    if com_state_error is None:
        return np.zeros((n, 6))
    x_bar = np.asarray(com_state_error, dtype=float)
    if x_bar.shape != (n, 6) or not np.all(np.isfinite(x_bar)):
        raise WbcError(f"CoM state error must be finite with shape ({n}, 6), got {x_bar.shape}")
    return x_bar
