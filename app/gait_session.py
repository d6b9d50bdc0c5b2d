"""The gait planner in the studio: settings from the gait panel, solves in the worker process
(app.jobs), live convergence, results beside the paper's Table 4, and the gait played like any
motion on dircon_biped.

The planner works on dircon_biped (the gait paper's robot). A result is marked stale when the
settings change after its solve was launched; a failed solve keeps the last good gait.
"""

from __future__ import annotations

import itertools
import threading
from typing import TYPE_CHECKING, Any

import viser

from app.core.errors import StudioError
from app.jobs import SolverWorker
from panels.gait_panel import PAPER_TABLE4, GaitPanel

if TYPE_CHECKING:
    from app.studio import Studio

PLANNER_ROBOT = "dircon_biped"
FACTORY = "app.gait_jobs:build_gait_problem"


class GaitSession:
    def __init__(self, studio: Studio) -> None:
        self._studio = studio
        self.panel = GaitPanel(studio.server.gui, self)
        self._lock = threading.Lock()
        self._worker: SolverWorker | None = None
        self._ids = itertools.count(1)
        self.running: tuple[str, bool, dict[str, float]] | None = None
        """(job id, baseline, panel values) of the solve under way."""
        self.results: dict[bool, Any] = {}
        """Last good result per kind (baseline or not)."""
        self.last: tuple[bool, Any, dict[str, float]] | None = None
        """(baseline, result, values) of the last finished solve, good or not."""
        self.history: tuple[list[int], list[float], list[float]] = ([], [], [])

    # --- worker ----------------------------------------------------------------------------

    def _ensure_worker(self) -> SolverWorker:
        if self._worker is None:
            worker = SolverWorker(FACTORY)
            worker.on_progress(self._on_progress)
            worker.on_done(self._on_done)
            worker.on_failed(self._on_failed)
            worker.on_cancelled(self._on_cancelled)
            self._worker = worker
        return self._worker

    def solve(self, baseline: bool, client: viser.ClientHandle | None = None) -> str | None:
        """Launch a solve with the panel's settings; returns its job id."""
        from app.core.collocation.settings import GaitSettings

        values = self.panel.values()
        try:
            settings = GaitSettings(
                slack_a=values["slack_a"],
                slack_b=values["slack_b"],
                K0=values["K0"],
                K1=values["K1"],
                K2=values["K2"],
                H_s=values["H_s"],
                step_length_m=values["step_length_m"],
                swing_height_m=values["swing_height_m"],
                swing_clearance_m=values["swing_clearance_m"],
                knots=int(values["knots"]),
                mu=values["mu"],
                baseline=baseline,
            ).validate()
        except (StudioError, TypeError, ValueError) as error:
            self._studio.report_error("Gait settings refused", str(error), client)
            return None
        job_id = f"gait-{next(self._ids)}"
        with self._lock:
            self.running = (job_id, baseline, values)
            self.history = ([], [], [])
        kind = "baseline (original DIRCON)" if baseline else "symmetric gait"
        self.panel.status.content = f"Solving the {kind} (job {job_id})…"
        self.panel.show_running(True)
        self._ensure_worker().submit(job_id, settings, (int(values["knots"]), baseline))
        return job_id

    def cancel(self) -> None:
        if self._worker is not None:
            self._worker.cancel()

    def close(self) -> None:
        if self._worker is not None:
            self._worker.close()
            self._worker = None

    # --- events from the worker (the "solver-events" thread) --------------------------------

    def _on_progress(self, job_id: str, iteration: int, objective: float, violation: float) -> None:
        with self._lock:
            if self.running is None or self.running[0] != job_id:
                return
            iterations, objectives, violations = self.history
            iterations.append(iteration)
            objectives.append(objective)
            violations.append(violation)
            history = (list(iterations), list(objectives), list(violations))
        self.panel.show_progress(min(1.0, iteration / 200.0))
        if len(history[0]) % 5 == 1:
            self.panel.show_convergence(*history)

    def _on_done(self, job_id: str, result: Any) -> None:
        with self._lock:
            if self.running is None or self.running[0] != job_id:
                return
            _, baseline, values = self.running
            self.running = None
            self.last = (baseline, result, values)
            if result.converged:
                self.results[baseline] = result
        self.panel.show_running(False)
        self.panel.show_convergence(*self.history)
        if result.converged:
            self.panel.status.content = (
                f"Solved in {result.solve_s:.1f} s, {result.iterations} IPOPT iterations."
            )
        else:
            kept = " The last good gait is kept." if baseline in self.results else ""
            self.panel.status.content = f"⚠️ Not solved: {result.status}.{kept}"
        self.show_results()

    def _on_failed(self, job_id: str, message: str) -> None:
        with self._lock:
            if self.running is None or self.running[0] != job_id:
                return
            self.running = None
        self.panel.show_running(False)
        self.panel.status.content = f"⚠️ {message}"

    def _on_cancelled(self, job_id: str) -> None:
        with self._lock:
            if self.running is None or self.running[0] != job_id:
                return
            self.running = None
        self.panel.show_running(False)
        self.panel.status.content = "Cancelled. The last good gait is kept."

    # --- results ---------------------------------------------------------------------------

    def settings_changed(self) -> None:
        """Mark shown results stale when the settings no longer match them."""
        self.show_results()

    def show_results(self) -> None:
        values = self.panel.values()
        rows = ["| | this planner | baseline | paper (sym. / prev.) |", "|---|---|---|---|"]
        sym, base = self.results.get(False), self.results.get(True)

        def cell(result: Any, attribute: str, fmt: str) -> str:
            return fmt.format(getattr(result, attribute)) if result is not None else "—"

        rows.append(
            f"| solve time [s] | {cell(sym, 'solve_s', '{:.1f}')} | {cell(base, 'solve_s', '{:.1f}')} | 65–300 |"
        )
        rows.append(
            f"| max \\|τ\\| [N·m] | {cell(sym, 'max_abs_tau_Nm', '{:.2f}')} | {cell(base, 'max_abs_tau_Nm', '{:.2f}')} "
            f"| {PAPER_TABLE4['max_abs_tau_Nm'][0]} / {PAPER_TABLE4['max_abs_tau_Nm'][1]} |"
        )
        rows.append(
            f"| SR | {cell(sym, 'sr', '{:.3f}')} | {cell(base, 'sr', '{:.3f}')} | {PAPER_TABLE4['sr'][0]} / {PAPER_TABLE4['sr'][1]} |"
        )
        for result, label in ((sym, "this planner"), (base, "baseline")):
            if result is not None:
                lsp, rsp = result.step_lengths_m
                rows.append(f"| steps LSP / RSP [m] ({label}) | {lsp:.3f} / {rsp:.3f} | | |")
        if sym is not None:
            rows.append(f"| slack0 | {sym.slack0:+.3f} | | |")
        rows.append(
            f"| symmetry residuals: exchange / periodicity | {_residuals(sym)} | {_residuals(base)} | |"
        )
        stale = self.last is not None and self.last[2] != values
        note = "\n\n⚠️ The settings changed since this solve: results are stale." if stale else ""
        self.panel.results.content = "\n".join(rows) + note
        self.panel.use.disabled = sym is None and base is None

    def play_result(self) -> None:
        """Send the last good gait to playback (and torque feed-forward) on dircon_biped."""
        from app.core.collocation.dircon import to_trajectory

        studio = self._studio
        result = self.results.get(False) or self.results.get(True)
        if result is None:
            return
        if studio.robot is None or studio.robot.name != PLANNER_ROBOT:
            self.load_planner_robot(None)
        robot = studio.robot
        if robot is None or robot.name != PLANNER_ROBOT:
            return
        trajectory = to_trajectory(robot, result)
        studio.set_trajectory(
            trajectory, f"**gait** — {trajectory.duration:.2f} s, from the planner"
        )

    def load_planner_robot(self, client: viser.ClientHandle | None) -> None:
        self._studio.load(PLANNER_ROBOT, client=client)

    def show_robot(self) -> None:
        """Offer to load dircon_biped when another robot is loaded."""
        robot = self._studio.robot
        other = robot is None or robot.name != PLANNER_ROBOT
        self.panel.robot_note.content = (
            "The planner plans for **dircon_biped**, the gait paper's robot (planar, 10 DOF)."
            + (" Load it to watch the gait." if other else "")
        )
        self.panel.load_robot.visible = other


def _residuals(result: Any) -> str:
    if result is None:
        return "—"
    return f"{result.exchange_residual:.1e} / {result.periodicity_residual:.1e}"
