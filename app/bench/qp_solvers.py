"""Bench entry "qp_solvers": the studio's whole-body QP beside DAQP, ProxQP and OSQP solving
the very same QP matrices.

The studio solves each sample's reduced QP (app.core.dynamics.wbc_reduced: 44 unknowns with
both feet down on servo_biped) in closed form for all samples of a chunk at once where no
inequality is active, and by DAQP on the sample's matrices where one is. The baselines build
every sample's matrices (`ReducedQp.problem`, the same call the studio makes) and hand them
to a general QP solver:

- DAQP 0.11 (dual active set, cold: its answer on the final active set is exact to round-off);
- ProxQP 0.8 (dense, warm-started from the previous sample with the same dimensions);
- OSQP 1.1.3 (ADMM, set up once per dimension with a dense pattern, then the sample's values
  updated and warm-started, polishing off);
all with the studio's tolerance (1e-6) where they take one.

Two figures per solver and robot, CPU time per sample (mean over the motion, since the studio
solves a chunk in bulk; thread CPU, each pass in a tight loop, best of the passes):
- the solve alone: the solver's call on the built matrices, beside the studio's solving
  (its batched closed form of every sample, and DAQP's calls where the closed form does not
  answer), timed inside its own chunks;
- with the assembly: the kinematics + the matrices + the solver, beside the studio's
  kinematics + closed form + the matrices and DAQP where it needs them (the torques and the
  certification that follow are left out of both).

Same solution: each answer is certified independently (`kkt_certificate`: feasibility, and
the stationarity residual with non-negative multipliers fitted by NNLS on the active rows),
and the objectives agree. The β coefficients themselves may differ between solvers by
newtons: ε = 1e-6 leaves directions where the cost is nearly flat (the forces' spread over
the sole corners); q̈, the objective and the net contact wrench are what is unique in
practice.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path

import daqp
import numpy as np
import osqp
import scipy.sparse as sp
from proxsuite import proxqp
from scipy.optimize import nnls

from app.bench.registry import BenchContext, bench_entry
from app.bench.report import Figure
from app.bench.timing import THREAD_CPU, percentiles_ms, stopwatch, tallied
from app.core.dynamics.wbc import (
    ChunkInput,
    WbcParams,
    chunk_bounds,
    make_qp,
    solve_chunk,
)
from app.core.dynamics.wbc_qp import MAX_ITERATIONS, TOLERANCE, WholeBodyQp
from app.core.dynamics.wbc_reduced import DAQP_INFINITY, ReducedProblem
from app.core.dynamics.wbc_terms import SampleInput
from app.core.motions.library import run_motion
from app.core.motions.trajectory import Trajectory
from app.core.robot.loading import load_robot

PASSES = 3
"""Passes over the motion per solver (and for the studio): per sample the fastest is kept."""
ACTIVE_TOLERANCE = 1e-6
"""A row is active (its multiplier may be non-zero) within this of its bound, relative to
max(1, |row value|)."""

Solver = Callable[[ReducedProblem], np.ndarray]


def stacked(problem: ReducedProblem) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The QP's rows as one matrix: G = [I 0; A] (β ≥ 0 first, then A's rows) and their bounds
    with ±inf for DAQP's stand-in."""
    nb, ny = len(problem.beta_columns), problem.H.shape[0]
    G = np.vstack([np.eye(nb, ny), problem.A])
    lower = np.where(problem.lower <= -DAQP_INFINITY, -np.inf, problem.lower)
    upper = np.where(problem.upper >= DAQP_INFINITY, np.inf, problem.upper)
    return G, lower, upper


def objective(problem: ReducedProblem, y: np.ndarray) -> float:
    return float(0.5 * y @ problem.H @ y + problem.f @ y)


def kkt_certificate(problem: ReducedProblem, y: np.ndarray) -> tuple[float, float]:
    """(largest bound violation, relative stationarity residual) of y, computed here from the
    matrices alone: the multipliers are fitted by non-negative least squares on the rows
    active at y, so a small residual says y is the QP's minimiser whatever solver gave it."""
    G, lower, upper = stacked(problem)
    g = G @ y
    violation = max(0.0, float(np.max(lower - g)), float(np.max(g - upper)))
    tolerance = ACTIVE_TOLERANCE * np.maximum(1.0, np.abs(g))
    at_lower, at_upper = g - lower <= tolerance, upper - g <= tolerance
    gradient = problem.H @ y + problem.f
    # H y + f = G_lowerᵀ μ − G_upperᵀ ν with μ, ν ≥ 0.
    normals = np.hstack([G[at_lower].T, -G[at_upper].T])
    residual = nnls(normals, gradient)[1] if normals.shape[1] else float(np.linalg.norm(gradient))
    scale = max(1.0, float(np.linalg.norm(problem.f)), float(np.linalg.norm(problem.H @ y)))
    return violation, float(residual) / scale


def solve_daqp(problem: ReducedProblem) -> np.ndarray:
    """DAQP on the sample's matrices, cold, as the studio calls it for its constrained samples."""
    y, _fval, flag, _info = daqp.solve(
        problem.H, problem.f, problem.A, problem.upper, problem.lower
    )
    return np.asarray(y) if flag >= 0 else np.full(problem.H.shape[0], np.nan)


class ProxQpWarm:
    """ProxQP (dense) on the sample's matrices, warm from the previous sample of the same size."""

    def __init__(self) -> None:
        self._qp: proxqp.dense.QP | None = None

    def __call__(self, problem: ReducedProblem) -> np.ndarray:
        G, lower, upper = stacked(problem)
        lower, upper = np.maximum(lower, -1e20), np.minimum(upper, 1e20)
        ny = problem.H.shape[0]
        if self._qp is None or self._qp.model.dim != ny or self._qp.model.n_in != len(G):
            qp = proxqp.dense.QP(ny, 0, len(G))
            qp.settings.eps_abs, qp.settings.eps_rel = TOLERANCE, 0.0
            qp.settings.max_iter, qp.settings.verbose = MAX_ITERATIONS, False
            qp.settings.initial_guess = proxqp.InitialGuess.WARM_START_WITH_PREVIOUS_RESULT
            qp.init(problem.H, problem.f, None, None, G, lower, upper)
            self._qp = qp
        else:
            self._qp.update(H=problem.H, g=problem.f, C=G, l=lower, u=upper)
        self._qp.solve()
        if self._qp.results.info.status != proxqp.PROXQP_SOLVED:
            return np.full(ny, np.nan)
        return np.array(self._qp.results.x)


class OsqpWarm:
    """OSQP on the sample's matrices: set up once per size with every entry in its pattern
    (the values change every sample), then updated and warm-started."""

    def __init__(self) -> None:
        self._solver: osqp.OSQP | None = None
        self._shape: tuple[int, int] = (0, 0)
        self._p_index: tuple[np.ndarray, np.ndarray] = (np.zeros(0, int), np.zeros(0, int))
        self._a_index: tuple[np.ndarray, np.ndarray] = (np.zeros(0, int), np.zeros(0, int))

    def __call__(self, problem: ReducedProblem) -> np.ndarray:
        G, lower, upper = stacked(problem)
        ny = problem.H.shape[0]
        if self._solver is None or self._shape != G.shape:
            columns, rows = np.tril_indices(ny)  # as (row, column): the upper triangle, CSC order
            self._p_index = (rows, columns)
            a_columns, a_rows = np.indices((ny, len(G))).reshape(2, -1)
            self._a_index = (a_rows, a_columns)
            P = sp.csc_matrix((problem.H[self._p_index], self._p_index), shape=(ny, ny))
            A = sp.csc_matrix((G[self._a_index], self._a_index), shape=G.shape)
            self._solver, self._shape = osqp.OSQP(), G.shape
            self._solver.setup(
                P, problem.f, A, lower, upper, verbose=False, eps_abs=TOLERANCE,
                eps_rel=TOLERANCE, polishing=False, warm_starting=True, max_iter=MAX_ITERATIONS,
            )  # fmt: skip
        else:
            self._solver.update(
                q=problem.f, l=lower, u=upper, Px=problem.H[self._p_index], Ax=G[self._a_index]
            )
        result = self._solver.solve(raise_error=False)
        if result.info.status != "solved" or result.x is None:
            return np.full(ny, np.nan)
        return np.asarray(result.x)


BASELINES: dict[str, Callable[[], Solver]] = {
    "DAQP": lambda: solve_daqp,
    "ProxQP": ProxQpWarm,
    "OSQP": OsqpWarm,
}
"""The baseline solvers by name, each made fresh per pass."""
BASELINE_WHAT = {
    "DAQP": "DAQP 0.11 (dual active set, cold)",
    "ProxQP": "ProxQP 0.8 (dense, warm from the last sample)",
    "OSQP": "OSQP 1.1.3 (warm, updated values, no polishing)",
}


@dataclasses.dataclass(frozen=True)
class SameQp:
    """Every sample's reduced QP of a motion and what building them cost."""

    problems: list[ReducedProblem]
    kinematics_cpu_s: float
    """The chunks' kinematics (one pinocchio pass per sample), total, best pass [s]."""
    assembly_cpu_s: np.ndarray
    """Per sample, `ReducedQp.problem` (the matrices from the kinematics), best pass [s]."""


def same_qp(qp: WholeBodyQp, traj: Trajectory, passes: int = PASSES) -> SameQp:
    """The reduced QP of every sample of `traj`, built as the studio builds it."""
    reduced = qp.reduced
    assert reduced is not None, "the robot's QP is not reducible"
    n = traj.n_samples
    kinematics, assembly = np.inf, np.full(n, np.inf)
    problems: list[ReducedProblem] = []
    no_error = np.zeros(6)
    for _ in range(passes):
        problems = []
        with stopwatch(THREAD_CPU) as lap:
            batches = [qp.kinematics_batch(traj.q[s:e], traj.v[s:e], traj.a[s:e])[0] for s, e in chunk_bounds(n)]  # fmt: skip
        kinematics = min(kinematics, lap.cpu_s)
        for (start, _stop), batch in zip(chunk_bounds(n), batches, strict=True):
            for i in range(len(batch.M)):
                k = start + i
                begin = THREAD_CPU()
                problems.append(
                    reduced.problem(
                        SampleInput(
                            qp.terms_at(batch, i), traj.v[k], traj.a[k], traj.contacts[k], no_error
                        )
                    )
                )
                assembly[k] = min(assembly[k], THREAD_CPU() - begin)
    return SameQp(problems, kinematics, assembly)


def solved_by(make: Callable[[], Solver], problems: list[ReducedProblem], passes: int = PASSES):
    """(answers (n, ny) per sample, CPU [s] per sample, best of the passes) of a solver."""
    times = np.full(len(problems), np.inf)
    answers: list[np.ndarray] = []
    for _ in range(passes):
        solver, answers = make(), []
        for k, problem in enumerate(problems):
            begin = THREAD_CPU()
            answers.append(solver(problem))
            times[k] = min(times[k], THREAD_CPU() - begin)
    return answers, times


def studio_cpu_s(qp: WholeBodyQp, traj: Trajectory, passes: int = PASSES) -> dict[str, float]:
    """The studio's chunks (`solve_chunk`), its QP's parts timed inside them (thread CPU, the
    pass with the least of them kept) [s]: "closed_form" (the batched closed form of every
    sample), "assembly" and "daqp" (the matrices and DAQP of the samples it leaves), "chunks"
    (the whole chunks, with the kinematics, torques and certification)."""
    reduced = qp.reduced
    assert reduced is not None, "the robot's QP is not reducible"
    params, best = WbcParams(), {"solve": np.inf}
    chunks = [
        ChunkInput(traj.q[s:e], traj.v[s:e], traj.a[s:e], traj.contacts[s:e], np.zeros((e - s, 6)))
        for s, e in chunk_bounds(traj.n_samples)
    ]
    parts = {"closed_form": "unconstrained_batch", "assembly": "problem", "daqp": "solve"}
    for _ in range(passes):
        laps: dict[str, list[float]] = {part: [] for part in parts}
        for part, method in parts.items():
            setattr(reduced, method, tallied(getattr(reduced, method), laps[part]))
        try:
            with stopwatch(THREAD_CPU) as lap:
                for chunk in chunks:
                    solve_chunk(qp, chunk, params)
        finally:
            for method in parts.values():
                delattr(reduced, method)  # the class's own again
        run = {part: float(sum(times)) for part, times in laps.items()}
        run["solve"] = run["closed_form"] + run["daqp"]
        run["chunks"] = lap.cpu_s
        if run["solve"] < best["solve"]:
            best = run
    return best


def studio_answers(
    qp: WholeBodyQp, traj: Trajectory, problems: list[ReducedProblem]
) -> tuple[list[np.ndarray], int]:
    """The studio's answer y = [β of the feet down, q̈ of the joints] per sample, by its own
    per-sample path (`WholeBodyQp.solve`: the closed form, else DAQP; NaN without one), and
    how many samples the closed form answered."""
    answers, closed = [], 0
    for k, problem in enumerate(problems):
        terms = qp.kinematics(traj.q[k], traj.v[k], traj.a[k])
        solution = qp.solve(SampleInput(terms, traj.v[k], traj.a[k], traj.contacts[k], np.zeros(6)))
        y = np.concatenate([solution.beta[problem.beta_columns], solution.qdd[6:]])
        answers.append(y if solution.ok else np.full_like(y, np.nan))
        closed += solution.ok and qp.last_reduced is None
    return answers, closed


def compare(problems: list[ReducedProblem], answers: dict[str, list[np.ndarray]]) -> dict:
    """Per solver: samples answered, worst KKT certificate, worst objective above the best of
    the solvers (relative), worst |Δq̈| from DAQP's."""
    best = np.array(
        [
            min(objective(p, a[k]) for a in answers.values() if np.all(np.isfinite(a[k])))
            for k, p in enumerate(problems)
        ]
    )
    rows = {}
    for name, ys in answers.items():
        finite = [k for k, y in enumerate(ys) if np.all(np.isfinite(y))]
        certificates = np.array([kkt_certificate(problems[k], ys[k]) for k in finite])
        gaps = [(objective(problems[k], ys[k]) - best[k]) / max(1.0, abs(best[k])) for k in finite]
        qdd = [float(np.abs(problems[k].T @ (ys[k] - answers["DAQP"][k])).max()) for k in finite]
        rows[name] = {
            "answered": len(finite),
            "max_violation": float(certificates[:, 0].max()),
            "max_stationarity": float(certificates[:, 1].max()),
            "max_objective_gap": float(max(gaps)),
            "max_qdd_difference": float(max(qdd)),
        }
    return rows


def bench_qp_solvers(source: str | Path, motion: str, passes: int = PASSES) -> dict:
    """The studio's QP and the baselines on every sample of `motion` (see the module
    docstring): CPU per sample [ms] and the agreement of the answers."""
    robot = load_robot(source)
    traj = run_motion(robot, motion, dt=0.01).trajectory
    qp = make_qp(robot, WbcParams())
    built = same_qp(qp, traj, passes)
    n = traj.n_samples
    studio = {part: seconds / n * 1e3 for part, seconds in studio_cpu_s(qp, traj, passes).items()}
    answers, closed = studio_answers(qp, traj, built.problems)
    kinematics_ms = built.kinematics_cpu_s / n * 1e3
    assembly_ms = float(built.assembly_cpu_s.mean() * 1e3)
    row: dict = {
        "robot": robot.name,
        "motion": motion,
        "samples": n,
        "unknowns": sorted({p.H.shape[0] for p in built.problems}),
        "rows": sorted({len(p.lower) for p in built.problems}),
        "studio_closed_form_samples": closed,
        "studio": studio,
        "studio_solve_ms": studio["solve"],
        "studio_with_assembly_ms": kinematics_ms + studio["solve"] + studio["assembly"],
        "kinematics_ms": kinematics_ms,
        "assembly_ms": assembly_ms,
        **percentiles_ms(built.assembly_cpu_s, "assembly_"),
    }
    all_answers = {"studio": answers}
    for name, make in BASELINES.items():
        ys, times = solved_by(make, built.problems, passes)
        all_answers[name] = ys
        solve_ms = float(times.mean() * 1e3)
        row[name] = {
            "solve_ms": solve_ms,
            **percentiles_ms(times),
            "with_assembly_ms": kinematics_ms + assembly_ms + solve_ms,
        }
    row["agreement"] = compare(built.problems, all_answers)
    return row


def _figures(key: str, row: dict) -> list[Figure]:
    agree = row["agreement"]
    same = (
        "same optimum (studio, DAQP, ProxQP, OSQP): KKT stationarity ≤ "
        f"{max(a['max_stationarity'] for a in agree.values()):.1e}, objective within "
        f"{max(a['max_objective_gap'] for a in agree.values()):.1e} (relative), "
        f"|Δq̈| ≤ {max(a['max_qdd_difference'] for a in agree.values()):.1e}"
    )
    shape = f"{'/'.join(map(str, row['unknowns']))} unknowns"
    figures = [
        Figure(
            f"whole-body QP per sample, the solve alone, {key} {row['motion']} "
            f"(CPU, mean of {row['samples']}) vs {name}",
            row["studio_solve_ms"],
            "ms",
            "",
            None,
            row[name]["solve_ms"],
            f"{BASELINE_WHAT[name]} on the same matrices ({shape}), solver call only",
            f"studio: the closed form of {row['samples']} samples at once "
            f"({row['studio']['closed_form']:.4f} ms each; the answer on "
            f"{row['studio_closed_form_samples']}), DAQP on the rest; {name} p95 "
            f"{row[name]['p95_ms']:.3f} ms" + (f"; {same}" if name == "DAQP" else ""),
        )
        for name in BASELINES
    ]
    others = ", ".join(f"{name} {row[name]['with_assembly_ms']:.3f} ms" for name in BASELINES)
    figures.append(
        Figure(
            f"whole-body QP per sample with kinematics and assembly, {key} {row['motion']} "
            f"(CPU, mean of {row['samples']})",
            row["studio_with_assembly_ms"],
            "ms",
            "",
            None,
            row["DAQP"]["with_assembly_ms"],
            "the same kinematics, the same matrices built per sample, then DAQP",
            f"the same with {others}; kinematics {row['kinematics_ms']:.3f} ms, the "
            f"matrices {row['assembly_ms']:.3f} ms (the studio builds them only where the closed "
            f"form does not answer: {row['studio']['assembly']:.3f} ms per sample)",
        )
    )
    return figures


@bench_entry("qp_solvers")
def _entry_qp_solvers(ctx: BenchContext) -> tuple[dict, list[Figure]]:
    rows = {"servo_biped": bench_qp_solvers("servo_biped", "one_leg_squats")}
    if ctx.roban is not None:
        rows["roban_s14"] = bench_qp_solvers(ctx.roban, "com_shift")
    return rows, [figure for key, row in rows.items() for figure in _figures(key, row)]
