"""The gait figures' baseline: the very same NLP handed to IPOPT through casadi with IPOPT's
and casadi's defaults (nlpsol differentiates the whole problem itself, IPOPT with its default
options and MUMPS), from the same start, bounds and parameters as the studio's solve.

Whatever the studio does to solve its gait faster (its own derivative blocks, options, another
solver, code generation) is measured against this one call, so a gait figure reads "the
studio's build + solve" over "the textbook casadi + IPOPT build + solve of the same problem".
To add a gait figure: time the studio's way, call `ipopt_defaults(problem, settings)` on the
same problem and settings, and put `build_cpu_s + solve_cpu_s` beside it.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from app.bench.timing import PROCESS_CPU, stopwatch

QUIET: dict[str, Any] = {"ipopt.print_level": 0, "ipopt.sb": "yes", "print_time": False}
"""Output off: not a solver option (IPOPT's defaults otherwise, max_iter 3000 included)."""


def defaults_solver(problem: Any, max_cpu_s: float | None = None) -> Any:
    """nlpsol with the defaults on the `GaitProblem`'s expressions (to reuse over points);
    `max_cpu_s`: IPOPT stops there (a bound on a baseline that may take many minutes, not a
    tuning: its status then says Maximum_CpuTime_Exceeded and its time is a lower bound)."""
    import casadi as ca

    nlp = problem.expressions()  # {"x", "p", "f", "g"}: the expressions the studio solves
    options = dict(QUIET)
    if max_cpu_s is not None:
        options["ipopt.max_cpu_time"] = float(max_cpu_s)
    return ca.nlpsol("baseline", "ipopt", nlp, options)


def ipopt_defaults(
    problem: Any,
    settings: Any,
    start_z: np.ndarray | None = None,
    solver: Any = None,
    max_cpu_s: float | None = None,
) -> dict:
    """Build (nlpsol on the problem's expressions, unless `solver` from `defaults_solver` is
    given: then the build costs 0) and solve the `GaitProblem`'s NLP for `settings` with the
    defaults, from `start_z` (else the problem's built-in guess, as a cold solve starts); CPU
    times [s] of both, IPOPT's iterations, status and objective."""
    lbx, ubx, lbg, ubg = problem._bounds(settings)
    x0 = problem._guess(settings) if start_z is None else start_z
    with stopwatch(PROCESS_CPU) as build:
        if solver is None:
            solver = defaults_solver(problem, max_cpu_s)
    with stopwatch(PROCESS_CPU) as solve:
        out = solver(
            x0=np.clip(x0, lbx, ubx),
            p=problem._parameters(settings),
            lbx=lbx,
            ubx=ubx,
            lbg=lbg,
            ubg=ubg,
        )
    stats = solver.stats()
    return {
        "build_cpu_s": build.cpu_s,
        "solve_cpu_s": solve.cpu_s,
        "total_cpu_s": build.cpu_s + solve.cpu_s,
        "iterations": int(stats.get("iter_count", -1)),
        "status": str(stats.get("return_status", "")),
        "objective": float(out["f"]),
    }
