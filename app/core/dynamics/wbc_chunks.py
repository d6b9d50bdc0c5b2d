"""The torque feed-forward's unit of work, a chunk of contiguous samples: the QP made for a
robot (make_qp), a chunk solved here (solve_chunk: the reduced QP in bulk, or the full QP warm
along the chunk), each sample certified against the plan's q̈ and the torque limits, and the
chunks' results stacked. The same code runs in the worker processes (parallel.py).
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from app.core.dynamics.lqr import lqr_com
from app.core.dynamics.wbc_params import WbcParams, torque_limits
from app.core.dynamics.wbc_qp import N_CORNERS, N_EDGES, QpSolver, QpWeights, WholeBodyQp
from app.core.dynamics.wbc_terms import SampleInput, TermsBatch
from app.core.robot.model import RobotModel

TORQUE_TOLERANCE = 1e-3
"""Relative excess over a torque limit tolerated as solver round-off."""
CHUNK_SAMPLES = 100
"""Samples per chunk: each chunk starts its QP cold and warm-starts along itself (a cold
sample costs a few warm ones), so chunks can be solved anywhere with the same answer."""


def chunk_bounds(n: int, size: int | None = None) -> list[tuple[int, int]]:
    """(start, stop) of the chunks of n samples, CHUNK_SAMPLES each (the last one shorter)."""
    size = size or CHUNK_SAMPLES
    return [(start, min(start + size, n)) for start in range(0, n, size)]


def make_qp(robot: RobotModel, params: WbcParams, solver: QpSolver = "reduced") -> WholeBodyQp:
    """The whole-body QP of a robot with these parameters (sparsity, cost, solver set up)."""
    bound, _ = torque_limits(robot, params)
    return WholeBodyQp(
        robot,
        QpWeights(
            mu=params.mu,
            alpha=params.alpha,
            w_qdd=params.w_qdd,
            epsilon=params.epsilon,
            eta_max=params.eta_max,
            a=params.a,
            q_lqr=params.lqr_q,
            r_lqr=params.lqr_r,
            S=lqr_com(params.lqr_q, params.lqr_r)[1],
            tau_max=bound,
        ),
        solver,
    )


def solve_chunk(qp: WholeBodyQp, chunk: ChunkInput, params: WbcParams) -> ChunkResult:
    """The QP at each sample of a chunk: the reduced QP in bulk (each sample on its own), or
    the full QP cold at the chunk's first sample and warm along it."""
    robot = qp.robot
    bound = qp.weights.tau_max
    n, nv = len(chunk.q), robot.model.nv
    tau = np.full((n, robot.n_actuated), np.nan)
    forces = np.full((n, 2, N_CORNERS, 3), np.nan)
    qdd = np.full((n, nv), np.nan)
    loop_forces = np.full((n, len(robot.tree.loops), 3), np.nan)
    times = np.empty(n)
    solver_times = np.zeros(n)
    solved = np.zeros(n, dtype=bool)
    status: list[str | None] = [None] * n
    beta = np.zeros((n, 2 * N_CORNERS * N_EDGES))
    qp.reset()
    if qp.reduced is not None:
        _solve_reduced_chunk(qp, chunk, qdd, tau, beta, solved, status, times, solver_times)
    for k in range(n if qp.reduced is None else 0):
        q, v, a = chunk.q[k], chunk.v[k], chunk.a[k]
        begin = time.perf_counter()
        terms = qp.kinematics(q, v, a)
        solution = qp.solve(SampleInput(terms, v, a, chunk.contacts[k], chunk.x_bar[k]))
        times[k] = time.perf_counter() - begin
        solver_times[k] = qp.last_solver_s
        if not solution.ok:
            status[k] = f"no solution: {solution.status}"
            continue
        solved[k] = True
        qdd[k] = solution.qdd
        tau[k] = qp.torques(terms, solution)
        beta[k] = solution.beta
        loop_forces[k] = solution.f_loop.reshape(-1, 3)
    # Forces and certification for the whole chunk at once; _certify words the exceptions.
    forces[solved] = qp.corner_forces(beta[solved])
    qdd_ok = np.abs(qdd - chunk.a).max(axis=1, initial=0.0) <= params.max_qdd_error
    tau_ok = np.all(np.abs(tau) - bound <= TORQUE_TOLERANCE * np.maximum(1.0, bound), axis=1)
    dof_names = _dof_names(robot)
    for k in np.flatnonzero(solved):
        status[k] = (
            "solved"
            if qdd_ok[k] and tau_ok[k]
            else _certify(qdd[k] - chunk.a[k], tau[k], bound, params, dof_names, robot)
        )
    return ChunkResult(
        tau, forces, qdd, loop_forces, times, solver_times, solved, tuple(map(str, status))
    )


def _solve_reduced_chunk(
    qp: WholeBodyQp,
    chunk: ChunkInput,
    qdd: np.ndarray,
    tau: np.ndarray,
    beta: np.ndarray,
    solved: np.ndarray,
    status: list[str | None],
    times: np.ndarray,
    solver_times: np.ndarray,
) -> None:
    """The reduced QP at every sample of a chunk, written into the arrays: the closed form
    for all samples of a contact state at once, the QP (DAQP) sample by sample where an
    inequality is active. A sample's time is its own pinocchio pass and constrained solve
    plus an equal share of the batched work."""
    assert qp.reduced is not None
    n = len(chunk.q)
    begin = time.perf_counter()
    batch, pin_s = qp.kinematics_batch(chunk.q, chunk.v, chunk.a)
    closed = time.perf_counter()
    ok = np.zeros(n, dtype=bool)
    states = chunk.contacts.astype(bool)
    for state in {(bool(left), bool(right)) for left, right in states}:
        idx = np.flatnonzero((states[:, 0] == state[0]) & (states[:, 1] == state[1]))
        part = TermsBatch(*(getattr(batch, f.name)[idx] for f in dataclasses.fields(batch)))
        qdd[idx], beta[idx], ok[idx] = qp.reduced.unconstrained_batch(
            part, chunk.v[idx], chunk.a[idx], state, chunk.x_bar[idx]
        )
    end = time.perf_counter()
    times[:] = pin_s + (end - begin - pin_s.sum()) / n
    solver_times[:] = (end - closed) / n
    for k in np.flatnonzero(~ok):
        begin = time.perf_counter()
        terms = qp.terms_at(batch, k)
        sample = SampleInput(terms, chunk.v[k], chunk.a[k], chunk.contacts[k], chunk.x_bar[k])
        solution = qp.solve(sample, closed_form=False)
        times[k] += time.perf_counter() - begin
        solver_times[k] += qp.last_solver_s
        if solution.ok:
            qdd[k], beta[k] = solution.qdd, solution.beta
            ok[k] = True
        else:
            qdd[k], beta[k] = np.nan, 0.0
            status[k] = f"no solution: {solution.status}"
    solved[:] = ok
    a = qp.actuated
    tau[ok] = (
        (batch.M[ok][:, a] @ qdd[ok][:, :, None])[:, :, 0]
        + batch.h[ok][:, a]
        - (batch.Phi[ok][:, a] @ beta[ok][:, :, None])[:, :, 0]
    )


@dataclasses.dataclass(frozen=True)
class ChunkInput:
    """Contiguous samples of a trajectory: q (n, nq), v, a (n, nv), contacts (n, 2), x̄ (n, 6)."""

    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    contacts: np.ndarray
    x_bar: np.ndarray


@dataclasses.dataclass(frozen=True)
class ChunkResult:
    """Per sample of a chunk, as in FeedForward (NaN rows where the QP had no solution)."""

    tau: np.ndarray
    forces: np.ndarray
    qdd: np.ndarray
    loop_forces: np.ndarray
    times: np.ndarray
    solver_times: np.ndarray
    solved: np.ndarray
    status: tuple[str, ...]


def stack_results(results: list[ChunkResult]) -> ChunkResult:
    """Consecutive chunks' results as one, sample rows in order (a pool task's compact answer)."""
    if len(results) == 1:
        return results[0]
    arrays = {
        field.name: np.concatenate([getattr(r, field.name) for r in results])
        for field in dataclasses.fields(ChunkResult)
        if field.name != "status"
    }
    return ChunkResult(**arrays, status=tuple(text for r in results for text in r.status))


def _certify(
    qdd_error: np.ndarray,
    tau: np.ndarray,
    bound: np.ndarray,
    params: WbcParams,
    dof_names: list[str],
    robot: RobotModel,
) -> str:
    """ "solved", or why not: the QP's dynamics hold exactly and its forces lie in the
    pyramids by construction; left to check are the plan's q̈ and the torque limits."""
    over = np.abs(tau) - bound
    joint = int(np.argmax(over))
    worst = int(np.argmax(np.abs(qdd_error)))
    if abs(qdd_error[worst]) > params.max_qdd_error:
        reason = (
            f"{robot.joint_names[joint]} is at its torque limit"
            if over[joint] > -TORQUE_TOLERANCE * max(1.0, bound[joint])
            else "the CoM leaves the support area, or friction is too low"
        )
        return (
            f"cannot follow the plan: q̈ of {dof_names[worst]} departs by "
            f"{abs(qdd_error[worst]):.3g} ({reason})"
        )
    if over[joint] > TORQUE_TOLERANCE * max(1.0, bound[joint]):
        return (
            f"torque limit: {robot.joint_names[joint]} needs {abs(tau[joint]):.3g}, "
            f"limit {bound[joint]:.3g} N·m"
        )
    return "solved"


def _dof_names(robot: RobotModel) -> list[str]:
    """A name per velocity coordinate: base_vx … base_wz, then the joints."""
    names = ["base_vx", "base_vy", "base_vz", "base_wx", "base_wy", "base_wz"]
    model = robot.model
    for jid in range(2, model.njoints):
        names += [model.names[jid]] * model.joints[jid].nv
    return names
