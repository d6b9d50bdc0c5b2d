"""GaitProblem: the paper's three-mode symmetric gait NLP (eq. 7), built once, solved many times.

The NLP itself (variables, constraints, cost) is built by gait_nlp.py; its parameters and
bounds per solve come from gait_bounds.py. Here: IPOPT's options, the built-in guess, and the
solve (cold, warm with a cold restart, or from a coarser mesh's optimum).
"""

from __future__ import annotations

import dataclasses
import functools
import time
from collections.abc import Callable
from typing import Any

import casadi as ca
import numpy as np

from app.core.collocation import nlp_cache
from app.core.collocation.blame import Scales, hardest_constraint
from app.core.collocation.gait_bounds import (
    BASE_PITCH_BOUNDS_RAD,
    BASE_PITCH_RATE_MAX,
    BASE_SPEED_MAX,
    BASE_Z_LOW_RATIO,
    gait_bounds,
    gait_parameters,
)
from app.core.collocation.gait_nlp import POSTURE_WEIGHT, build_gait_nlp
from app.core.collocation.guess import initial_guess
from app.core.collocation.mesh_interpolation import interpolate_point
from app.core.collocation.nlp import CompiledNlp, IterationCallback, SolveOutcome, SxNlp
from app.core.collocation.planar_model import PlanarModel
from app.core.collocation.readout import read_result
from app.core.collocation.result import GaitResult
from app.core.collocation.settings import GaitSettings, GaitSettingsError
from app.core.collocation.transcription import GaitLayout
from app.core.robot.model import RobotModel

__all__ = [
    "BASE_PITCH_BOUNDS_RAD",
    "BASE_PITCH_RATE_MAX",
    "BASE_SPEED_MAX",
    "BASE_Z_LOW_RATIO",
    "COARSE_KNOTS",
    "FINAL_WARM_STATUSES",
    "IPOPT_OPTIONS",
    "POSTURE_WEIGHT",
    "REFINE_ABOVE_KNOTS",
    "WARM_ITERATIONS_BEFORE_FALLBACK",
    "GaitProblem",
]

IPOPT_OPTIONS: dict[str, Any] = {
    "ipopt.print_level": 0,
    "print_time": False,
    "ipopt.sb": "yes",
    "ipopt.linear_solver": "mumps",
    # MUMPS's own row/column scaling of the KKT matrix: off. On the paper's case it took IPOPT
    # 81 iterations with it and 47 without (same optimum); the other robots are unchanged.
    "ipopt.mumps_scaling": 0,
    "ipopt.mumps_permuting_scaling": 0,
    # MUMPS's threshold pivoting: 1e-10 instead of IPOPT's 1e-6 (raised at most to 1e-6 when
    # IPOPT asks for more accuracy, instead of 0.1): fewer delayed pivots, less fill. The same
    # iterates to 1e-11 on the paper's case, servo_biped and Roban S14, 10–25 % less CPU per
    # iteration (most near an optimum: the warm re-solves). A pivot tolerance of 0 changes
    # the inertia IPOPT sees and takes more iterations (docs/speed.md, "The gait planner").
    "ipopt.mumps_pivtol": 1e-10,
    "ipopt.mumps_pivtolmax": 1e-6,
    # The first barrier parameter of the symmetric gait (the baseline keeps IPOPT's 0.1, see
    # GaitProblem): 0.5 instead of 0.1. From the built-in guess IPOPT spends
    # its first ~35 iterations at the first barrier parameter getting feasible with short
    # steps; a larger one keeps the iterates further inside their bounds and gets there in
    # fewer (46 → 34 on the paper's case, 31 → 27 on servo_biped, 62 → 45 on Roban S14, the
    # same optima to 1e-9; tests/core/test_gait_ipopt_options.py). Warm starts set their own
    # (1e-4).
    "ipopt.mu_init": 0.5,
    "ipopt.tol": 1e-6,
    "ipopt.constr_viol_tol": 1e-6,
    "ipopt.acceptable_tol": 1e-4,
    "ipopt.acceptable_iter": 10,
    "ipopt.max_iter": 100000,  # the per-solve limit is GaitSettings.max_iter, via the callback
    # Monotone barrier updates. The adaptive strategy took 25 iterations instead of 46 on the
    # paper's case (first barrier parameter 0.1; 23 vs 31 on servo_biped, 33 vs 63 on Roban
    # S14) to the same optima (tests/core/test_gait_speed.py), but on settings that admit no
    # gait (|τ| ≤ 0.1 N·m) it runs to the iteration limit at a point where the torques are off
    # their bound, so the one line blames the clearance and periodicity instead of the torque
    # bound; monotone ends (at the iteration limit at 12 knots, or "Infeasible_Problem_Detected")
    # with the torques at their bound, which the line then blames (test_cli.py, test_dircon.py).
    "ipopt.mu_strategy": "monotone",
}
WARM_ITERATIONS_BEFORE_FALLBACK = 40
"""Iterations a warm start (from the previous solution, with its multipliers when it has them)
gets before the solve restarts cold from the built-in guess with the rest of max_iter
(measured: 5–15 iterations after one slider step on the built-ins and Roban S14; a cold solve
takes 25–50). A warm start that has not converged by then is stalled, not slow: before this
restart the K0 6.5 → 2 re-solve on servo_biped spent 1000 iterations (~200 s) on one point."""
FINAL_WARM_STATUSES = ("User_Requested_Stop", "Infeasible_Problem_Detected")
"""A warm start ending so is not restarted: stopped on request, or IPOPT converged to a point
of locally least infeasibility (tau_max 0.1 N·m: "the settings admit no gait" in 36 iterations,
where a cold restart spends the rest of max_iter without a verdict)."""
REFINE_ABOVE_KNOTS = 38
"""A first solve (no warm start) of more knots than this starts from a COARSE_KNOTS solve
interpolated onto its mesh (app.core.collocation.mesh_interpolation): at 160 knots a few seconds of CPU
instead of minutes from the guess. Building the coarse problem costs ~1.5 s of CPU now that
the NLP's derivatives are assembled from per-knot blocks (nlp.py), so refinement pays
whenever the mesh is finer than the coarse one."""
COARSE_KNOTS = 38
GUESSES_KEPT = 4
"""Built-in guesses a problem keeps (GaitProblem._guess)."""


class GaitProblem:
    """The NLP for one structure (knots, baseline); `solve` re-solves it for any slider values."""

    def __init__(
        self,
        robot: RobotModel | PlanarModel | None = None,
        knots: int = 38,
        baseline: bool = False,
        *,
        hessian: str = "exact",
        compile_derivatives: bool = False,
    ) -> None:
        """Build the NLP for dircon_biped (or `robot`): `hessian` is "exact" (default, about 20
        iterations) or "limited-memory" (L-BFGS: thousands of iterations here, kept for
        comparison). An NLP saved for this robot and structure before is read from the disk
        cache (nlp_cache.py) instead of built; else derivatives compiled for its block kinds
        are loaded from the codegen cache (nlp_codegen.py). With `compile_derivatives`, missing
        ones are compiled into it in the background (~35 s of CPU once), and a build whose
        kinds all had them is saved, for the next build."""
        if not isinstance(robot, RobotModel | PlanarModel | None):
            raise TypeError(f"GaitProblem's first argument is the robot, not {robot!r}")
        GaitSettings(knots=knots, baseline=baseline).validate()
        start = time.perf_counter()
        if robot is None:
            from app.core.robot.loading import load_robot

            robot = load_robot("dircon_biped")
        self.model = robot if isinstance(robot, PlanarModel) else PlanarModel(robot)
        self.layout = GaitLayout.from_knots(knots)
        self.structure = (knots, baseline)
        self.baseline = baseline
        self.knot_swing: list[slice] = []
        """The swing-foot height rows of each node (gait_nlp.build_gait_nlp)."""
        options = dict(IPOPT_OPTIONS)
        if baseline:
            # IPOPT's own first barrier parameter (0.1): the baseline's NLP (free mode
            # durations, no exchange) has several local optima close together, and 0.5 ends
            # in another one (the paper's case: 321.02 instead of 322.68; at 12 knots 382.3
            # instead of 343.9).
            options.pop("ipopt.mu_init")
        if hessian != "exact":
            options["ipopt.hessian_approximation"] = "limited-memory"
        key = nlp_cache.problem_key(self.model, knots, baseline, hessian == "exact")
        # A subclass that builds another NLP (the tests' inlined one) never reads this one's.
        standard = type(self)._build is GaitProblem._build
        saved = nlp_cache.load(key) if standard else None
        self.from_cache = saved is not None
        """Whether the NLP's functions were read from the disk cache (nlp_cache.py) rather
        than built."""
        if saved is not None:
            self.nlp = SxNlp.restored(
                saved.x_blocks, saved.g_blocks, saved.p_index, saved.nx, saved.ng
            )
            self.knot_swing = saved.knot_swing
            self.compiled: CompiledNlp = saved.compile(options)
        else:
            self.nlp = SxNlp()
            self._build()
            self.compiled = self.nlp.compile(options, compile_missing=compile_derivatives)
            if compile_derivatives and standard:
                nlp_cache.save(key, self.nlp, self.knot_swing, self.compiled)
        self.compiled.warm_solver()  # built now, so that the first slider re-solve does not pay it
        self.build_s = time.perf_counter() - start
        """Time to build the NLP and IPOPT's derivative functions [s]."""
        self.last_good: GaitResult | None = None
        """The last converged result: the default warm start, kept through failed solves."""
        self._coarse: GaitProblem | None = None
        """The 38-knot problem whose solve starts a fine mesh's first solve, built on use."""
        self._guesses: dict[tuple[float, ...], np.ndarray] = {}
        """The built-in guess by the settings it depends on (a few kept): a per-node leg IK
        that costs about as much as a warm re-solve, the same for every sweep point that
        changes only weights or bounds."""

    def _build(self) -> None:
        """The NLP's variables, constraints and cost, added to self.nlp (gait_nlp.py)."""
        self.knot_swing = build_gait_nlp(self.nlp, self.model, self.layout, self.baseline)

    def expressions(self) -> dict[str, Any]:
        """The NLP's SX expressions {"x", "p", "f", "g"} (the same variables and rows as the
        solver's), built now when the NLP was read from the disk cache (the bench's baseline
        hands them to nlpsol with its defaults)."""
        if self.compiled.problem is not None:
            return self.compiled.problem
        nlp = SxNlp()
        build_gait_nlp(nlp, self.model, self.layout, self.baseline)
        return {
            "x": ca.vertcat(*nlp._x), "p": ca.vertcat(*nlp._p), "f": nlp.cost,
            "g": ca.vertcat(*nlp._g),
        }  # fmt: skip

    # -- solving -------------------------------------------------------------------------------

    def _parameters(self, s: GaitSettings) -> np.ndarray:
        return gait_parameters(self.nlp, s)

    def _bounds(self, s: GaitSettings) -> tuple[np.ndarray, ...]:
        return gait_bounds(self, s)

    def _guess(self, s: GaitSettings) -> np.ndarray:
        """The built-in starting point for `s` (depends on H, step length and swing height)."""
        key = (s.H_s, s.step_length_m, s.swing_height_m)
        if key not in self._guesses:
            while len(self._guesses) >= GUESSES_KEPT:
                self._guesses.pop(next(iter(self._guesses)))
            self._guesses[key] = self._new_guess(s)
        return self._guesses[key].copy()

    def _new_guess(self, s: GaitSettings) -> np.ndarray:
        L, blocks = self.layout, self.nlp.x_blocks
        durations = np.array(L.symmetric_durations(s.H_s), dtype=float)
        times = L.node_times(durations)
        g = initial_guess(self.model, L, times, s.H_s, s.step_length_m, s.swing_height_m)
        x = np.zeros(self.nlp.nx)
        for name in ("q", "v", "a", "u", "lam"):
            for k, sl in enumerate(blocks[name]):
                x[sl] = g[name][k]
        pairs = [(k, k + 1) for j in range(3) for k in list(L.nodes(j))[:-1]]
        for (k0, k1), sl in zip(pairs, blocks["lam_mid"], strict=True):
            x[sl] = 0.5 * (g["lam"][k0] + g["lam"][k1])
        if self.baseline:
            x[blocks["T"][0]] = durations
            x[blocks["x1"][0]] = 0.5 * s.step_length_m
        return x

    def solve(
        self,
        settings: GaitSettings,
        warm_start: GaitResult | None = None,
        iteration_callback: IterationCallback | None = None,
        *,
        cold: bool = False,
        start_z: np.ndarray | None = None,
    ) -> GaitResult:
        """Solve for `settings`. Starts from `warm_start` if it is a converged result of this
        structure, else from the last converged solution of this problem, else (or with
        cold=True) from the built-in guess; a warm start that does not converge within
        WARM_ITERATIONS_BEFORE_FALLBACK iterations restarts cold (the result's
        `warm_iterations_before_cold` says so). Never raises for bad settings or a failed solve:
        the result says what happened, and `last_good` keeps the last converged gait.
        `iteration_callback(iteration, objective, violation)` runs at every IPOPT iteration and
        may return True to stop the solve. `start_z` (nx,) is a primal starting point given
        directly (e.g. a coarser mesh's optimum interpolated, app.core.collocation.mesh_interpolation)."""
        try:
            settings.validate()
        except GaitSettingsError as error:
            return GaitResult.refused(settings, f"invalid settings: {error}")
        if settings.structure != self.structure:
            return GaitResult.refused(
                settings,
                f"invalid settings: this problem is built for knots = {self.structure[0]}, "
                f"baseline = {self.structure[1]}; build another GaitProblem",
            )
        start = self.last_good
        if (
            isinstance(warm_start, GaitResult)
            and warm_start.converged
            and warm_start.structure == self.structure
        ):
            start = warm_start
        x0 = self._guess(settings) if cold or start is None else start.z
        if (
            start_z is None
            and start is None
            and not cold
            and self.structure[0] > REFINE_ABOVE_KNOTS
        ):
            refined = self._refined_start(settings, iteration_callback)
            if isinstance(refined, GaitResult):  # stopped during the coarse solve
                return dataclasses.replace(refined, settings=settings)
            start_z = refined
        if start_z is not None:
            if start_z.shape != (self.nlp.nx,):
                raise ValueError(f"start_z has shape {start_z.shape}, need ({self.nlp.nx},)")
            x0, start = start_z, None
        lbx, ubx, lbg, ubg = self._bounds(settings)
        run = functools.partial(
            self.compiled.run, p=self._parameters(settings),
            lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg, callback=iteration_callback,
        )  # fmt: skip
        warm_iterations = 0
        try:
            if cold or start is None:
                outcome = run(np.clip(x0, lbx, ubx), max_iter=settings.max_iter)
            else:
                outcome, warm_iterations = self._warm_run(
                    run, np.clip(x0, lbx, ubx), lambda: np.clip(self._guess(settings), lbx, ubx),
                    start, settings.max_iter, iteration_callback,
                )  # fmt: skip
        except RuntimeError as error:
            return GaitResult.refused(settings, f"the solver failed: {error}")
        result = read_result(outcome, settings, self.model, self.layout, self.nlp.x_blocks)
        result = dataclasses.replace(result, warm_iterations_before_cold=warm_iterations)
        if result.converged:
            self.last_good = result
            return result
        scales = Scales(
            self.model.mass_kg * self.model.gravity, self.model.standing_height_m,
            self.model.gravity,
        )  # fmt: skip
        blame = hardest_constraint(outcome, self.nlp, (lbg, ubg), settings, (lbx, ubx), scales)
        return dataclasses.replace(result, blame=blame)

    def _refined_start(
        self, settings: GaitSettings, iteration_callback: IterationCallback | None = None
    ) -> np.ndarray | GaitResult | None:
        """The COARSE_KNOTS optimum for these settings on this mesh, None if it fails, or the
        coarse result if `iteration_callback` stopped it. The callback sees the coarse
        solve's iterations first, then (from 0 again) the fine solve's."""
        if self._coarse is None:
            self._coarse = GaitProblem(self.model, COARSE_KNOTS, self.baseline)
        coarse = self._coarse.solve(
            dataclasses.replace(settings, knots=COARSE_KNOTS),
            iteration_callback=iteration_callback,
        )
        if coarse.ipopt_status == "User_Requested_Stop":
            return coarse
        if not coarse.converged:
            return None
        return interpolate_point(self._coarse, coarse.z, self)

    def _has_multipliers(self, result: GaitResult) -> bool:
        return result.lam_x.shape == (self.nlp.nx,) and result.lam_g.shape == (self.nlp.ng,)

    def _warm_run(
        self,
        run: Callable[..., SolveOutcome],
        x_warm: np.ndarray,
        x_guess: Callable[[], np.ndarray],
        start: GaitResult,
        max_iter: int,
        iteration_callback: IterationCallback | None,
    ) -> tuple[SolveOutcome, int]:
        """Warm start from `start` (primal-dual when it has multipliers), restarting cold from
        the built-in guess (`x_guess()`, computed only then) when that has not converged
        within WARM_ITERATIONS_BEFORE_FALLBACK iterations or failed otherwise (but not with FINAL_WARM_STATUSES). Returns the outcome
        and the iterations of the abandoned warm attempt (0 when none was abandoned); seconds
        and iterations of both attempts add up, and the callback sees the cold attempt's
        iterations numbered on from the warm ones."""
        budget = min(max_iter, WARM_ITERATIONS_BEFORE_FALLBACK)
        multipliers = (start.lam_x, start.lam_g) if self._has_multipliers(start) else None
        warm = run(x_warm, max_iter=budget, multipliers=multipliers)
        if warm.converged or warm.raw_status in FINAL_WARM_STATUSES or budget >= max_iter:
            return warm, 0
        offset = warm.iterations + 1  # the callback saw iterations 0 … warm.iterations

        def numbered_on(iteration: int, objective: float, violation: float) -> bool | None:
            assert iteration_callback is not None
            return iteration_callback(offset + iteration, objective, violation)

        callback = numbered_on if iteration_callback is not None else None
        cold = run(x_guess(), max_iter=max_iter - warm.iterations, callback=callback)
        outcome = dataclasses.replace(
            cold,
            seconds=warm.seconds + cold.seconds,
            iterations=warm.iterations + cold.iterations,
        )
        return outcome, warm.iterations
