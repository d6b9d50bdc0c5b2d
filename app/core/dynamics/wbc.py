"""Torque feed-forward τ(t) of a planned motion: CoM LQR + whole-body QP, friction pyramids.

The spring-compensation paper (Wang et al. 2023, Secs. 3–4) gets the joint torques its spring
compensation q_des = q + k·τ (eq. 7) needs from a whole-body QP (eqs. 12–18) over the joint
accelerations q̈ and the contact forces at the four corners of each rectangular sole, whose
cost contains the value function V of a CoM LQR (eqs. 1–5). τ then follows from eq. 10. The
QP itself is in app.core.dynamics.wbc_qp (made small in wbc_reduced); this module checks
inputs, runs it over chunks of samples and returns a FeedForward. With the reduced QP a chunk
is solved in bulk: one pinocchio pass per sample, the closed form (no inequality active) for
all samples of a contact state at once, DAQP for the others.

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
import math
import time
from collections.abc import Callable
from typing import Protocol

import numpy as np

from app.core.dynamics.lqr import lqr_com
from app.core.dynamics.wbc_qp import N_CORNERS, N_EDGES, QpSolver, QpWeights, WholeBodyQp
from app.core.dynamics.wbc_terms import SampleInput, TermsBatch
from app.core.errors import StudioError
from app.core.motions.trajectory import Trajectory
from app.core.robot.model import RobotModel

MAX_SPEED = 1e3
"""Largest |v| accepted in a trajectory [rad/s or m/s]; more is taken as corrupt input."""
MAX_ACCELERATION = 1e5
"""Largest |a| accepted in a trajectory [rad/s² or m/s²]."""
TORQUE_TOLERANCE = 1e-3
"""Relative excess over a torque limit tolerated as solver round-off."""
CHUNK_SAMPLES = 100
"""Samples per chunk: each chunk starts its QP cold and warm-starts along itself (a cold
sample costs a few warm ones), so chunks can be solved anywhere with the same answer."""


class WbcError(StudioError):
    """A torque feed-forward that cannot be computed for these inputs."""


@dataclasses.dataclass(frozen=True)
class WbcParams:
    """Parameters of the whole-body QP (eq. 12–18) and of the CoM LQR (eqs. 1–5)."""

    mu: float = 0.7
    """Coulomb friction coefficient of the pyramids (eq. 11). The paper gives no value; 0.7
    is a common rubber-sole-on-floor figure (the gait paper plans with 0.6)."""
    alpha: float = 10.0
    """No-slip gain α of eq. 14 [1/s] (not given in the paper)."""
    w_qdd: float = 100.0
    """Weight of ‖q̈_des − q̈‖² in eq. 12 [per (rad/s²)²] (not given in the paper). 100 ≫ the
    unit weight of ‖η‖² makes the plan authoritative: the slack absorbs the small foot
    accelerations finite differences leave in a plan, instead of q̈ bending away from it."""
    epsilon: float = 1e-6
    """ε of eq. 12 [per N²] (not given): only picks the smallest spread of forces over the
    corners; 1e-4 already bends q̈ of a 29 kg robot by ~4e-3 rad/s² on one leg."""
    eta_max: float = 10.0
    """Bound of the no-slip slack η of eq. 18 [m/s², rad/s²] (not given)."""
    lqr_q: float = 10.0
    """Q = lqr_q·I₆ of the CoM LQR (paper: 10)."""
    lqr_r: float = 0.1
    """R = lqr_r·I₃ of the CoM LQR (paper: 0.1)."""
    a: float = 0.1
    """Feed-through a of the CoM output y = p + a·u (eq. 1; paper: 0.1) [s²]."""
    torque_limits_Nm: tuple[float | None, ...] | None = None
    """|τ| bound per actuated joint [N·m or N], robot order (eq. 15). None: the URDF's effort
    limits; a joint without one (None here or in the URDF) is unbounded."""
    max_qdd_error: float = 0.1
    """A sample is "solved" when max |q̈ − q̈_des| stays below this [rad/s² or m/s²]."""

    def __post_init__(self) -> None:
        positive = {
            "mu": self.mu,
            "w_qdd": self.w_qdd,
            "epsilon": self.epsilon,
            "eta_max": self.eta_max,
            "lqr_q": self.lqr_q,
            "lqr_r": self.lqr_r,
            "max_qdd_error": self.max_qdd_error,
        }
        for name, value in {**positive, "alpha": self.alpha, "a": self.a}.items():
            bad = not math.isfinite(value) or value < 0.0 or (name in positive and value == 0.0)
            if bad:
                kind = "positive" if name in positive else "non-negative"
                raise WbcError(f"WBC parameter {name} must be a {kind} number, got {value!r}")
        for limit in self.torque_limits_Nm or ():
            if limit is not None and not (math.isfinite(limit) and limit >= 0.0):
                raise WbcError(f"torque limits must be non-negative numbers or None, got {limit!r}")


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


def torque_limits(robot: RobotModel, params: WbcParams) -> tuple[np.ndarray, list[str]]:
    """|τ| bound per actuated joint [N·m or N], inf where unbounded, and the unbounded names."""
    if params.torque_limits_Nm is None:
        limits = [joint.effort for joint in robot.joints]
    elif len(params.torque_limits_Nm) != robot.n_actuated:
        raise WbcError(
            f"{len(params.torque_limits_Nm)} torque limits given; {robot.name!r} has "
            f"{robot.n_actuated} actuated joints: {', '.join(robot.joint_names)}"
        )
    else:
        limits = list(params.torque_limits_Nm)
    bound = np.array([np.inf if limit is None else limit for limit in limits], dtype=float)
    return bound, [name for name, b in zip(robot.joint_names, bound, strict=True) if np.isinf(b)]


def torque_feedforward(
    robot: RobotModel,
    trajectory: Trajectory,
    params: WbcParams = WbcParams(),
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


def _nearest(solved: np.ndarray, k: int) -> int:
    """Index of the solved sample nearest to k (the earlier one on a tie)."""
    indices = np.flatnonzero(solved)
    return int(indices[np.argmin(np.abs(indices - k))])


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


def _dof_names(robot: RobotModel) -> list[str]:
    """A name per velocity coordinate: base_vx … base_wz, then the joints."""
    names = ["base_vx", "base_vy", "base_vz", "base_wx", "base_wy", "base_wz"]
    model = robot.model
    for jid in range(2, model.njoints):
        names += [model.names[jid]] * model.joints[jid].nv
    return names
