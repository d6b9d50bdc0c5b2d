"""The gait planner in the studio: settings from the gait panel (the loaded robot's defaults),
solves in the worker process (app.jobs), live convergence, results beside the paper's Table 4,
and the planned cycle walked for N steps (a whole-body motion, with footprints) like any motion.

The planner works on the loaded robot when its legs reduce to the sagittal plane (three
built-ins but the hybrid leg's loops, Roban S14, SigmaBan, …); the panel says why when they do
not. A result is marked stale when the settings change after its solve was launched; a failed
solve keeps the last good gait; results belong to their robot.
"""

from __future__ import annotations

import dataclasses
import logging
import time
from pathlib import Path
from typing import Any

import numpy as np
import viser

from app.core.collocation.defaults import robot_gait_defaults
from app.core.collocation.gait_problem import COARSE_KNOTS, WARM_ITERATIONS_BEFORE_FALLBACK
from app.core.collocation.planar_model import PlanarModel
from app.core.collocation.result import GaitResult
from app.core.collocation.settings import GaitSettings
from app.core.errors import StudioError
from app.core.projects.project import Project
from app.core.robot.loading import load_robot
from app.core.robot.report import robot_report
from app.core.walking.walk import Walk, build_walk
from app.studio.gait_default_step import DefaultStep
from app.studio.gait_solves import GaitSolves
from app.studio.gait_text import GaitResults, Solve, results_table, stage_words, status_line
from app.studio.gait_walks import ShownWalk
from app.studio.gait_worker import GaitWorker
from app.studio.notifier import Notifier
from app.studio.signals import Signal
from app.studio.state import LoadedRobot, StudioState
from app.views.footprints_view import FootprintsView
from panels.gait_panel import GaitPanel
from panels.quiet import set_value

log = logging.getLogger(__name__)

PAPER_ROBOT = "dircon_biped"
PIPELINE_STAGES = ("torques", "simulate")
"""What the one-click pipeline asks of the walk after planning it."""
MAX_PROGRESS_ITERATIONS = 200.0
"""The progress bar is full after this many IPOPT iterations (most solves take 10–70)."""


class GaitSession:
    """Owns the Gait panel and the solver worker (`worker`, app/studio/gait_worker.py)."""

    def __init__(
        self,
        server: viser.ViserServer,
        state: StudioState,
        notifier: Notifier,
        package_roots: tuple[Path, ...] = (),
        *,
        prepare: bool = False,
    ) -> None:
        self._server, self._state, self._notifier = server, state, notifier
        self.panel = GaitPanel(server.gui, self)
        self.planar: PlanarModel | None = None
        """The loaded robot's planar model, None when the planner cannot handle it."""
        self._shown = ShownWalk(server)
        self.worker = GaitWorker(self._on_progress, self._end, prepare_ahead=prepare)
        """The solver worker (started on first need)."""
        self.solves = GaitSolves(package_roots)
        """The solve under way (`solves.running`), the last, its convergence history."""
        self.results = GaitResults()
        self.default_step = DefaultStep()
        """The search for a default step whose walk can start (S14's is too long)."""
        self._pipeline_job: str | None = None
        """The solve whose end continues the one-click pipeline."""
        self.progressed: Signal[int] = Signal("gait_progressed")
        """Emitted with the iteration after the panel showed a solve's progress (every tab sees
        the panel: a tab opened during a solve sees how far it is)."""
        self.finished: Signal[Solve] = Signal("gait_finished")
        """Emitted once per solve when it ends (converged, failed or cancelled), after the
        panel shows it."""
        self.pipeline_started: Signal[str] = Signal("pipeline_started")
        """Emitted when the one click is taken, with its first stage ("planning", or
        "walking" when the last gait still fits the settings)."""
        state.on_robot.connect(self._on_robot)
        state.on_motion.connect(self._shown.on_motion)

    @property
    def walk(self) -> Walk | None:
        """The walk last sent to playback."""
        return self._shown.walk

    @property
    def footprints(self) -> FootprintsView | None:
        return self._shown.footprints

    @property
    def prepared(self) -> Signal[object]:
        """Emitted with the structure key when the worker has built a problem ahead of time."""
        return self.worker.prepared

    # --- projects (HoldsWork) -------------------------------------------------------------------

    def snapshot(self) -> dict[str, object]:
        walk = self.walk
        try:
            settings: GaitSettings | None = self.panel.settings(False)
        except StudioError:
            settings = None
        return {
            "gait_settings": settings,
            "gait_steps": int(self.panel.steps.value),
            "gait_symmetric": self.results.symmetric,
            "gait_baseline": self.results.baseline,
            "walk": walk
            if walk is not None and walk.trajectory is self._state.trajectory
            else None,
        }

    def restore(self, project: Project) -> None:
        """The project's gaits (those of this robot's planar joints) and settings."""
        planar = self.planar
        joints = planar.joint_names if planar is not None else None

        def fits(result: GaitResult | None) -> GaitResult | None:
            return result if result is not None and result.joint_names == joints else None

        self.results = GaitResults(fits(project.gait_symmetric), fits(project.gait_baseline))
        self.solves.forget_last()
        if planar is not None and project.gait_settings is not None:
            self.panel.show_settings(project.gait_settings)
        if 1 <= project.gait_steps <= 20:
            set_value(self.panel.steps, project.gait_steps)
        self.show_results()
        walk, robot, trajectory = project.walk, self._state.robot, self._state.trajectory
        if walk is not None and robot is not None and trajectory is not None:
            walked = walk.trajectory
            if walked.q.shape == trajectory.q.shape and np.array_equal(walked.q, trajectory.q):
                shown = dataclasses.replace(walk, trajectory=trajectory)  # the one shown
                self._shown.walk = shown
                self._shown.show_footprints(robot, shown)

    # --- solves in the worker ------------------------------------------------------------------

    def solve(self, baseline: bool, client: viser.ClientHandle | None = None) -> str | None:
        """Launch a solve with the panel's settings on the loaded robot; returns its job id."""
        robot, planar = self._state.robot, self.planar
        if robot is None or planar is None or planar.robot is not robot:
            self._notifier.error("No gait for this robot", self.panel.robot_note.content, client)
            return None
        try:
            settings = self.panel.settings(baseline)
        except StudioError as error:
            self.panel.status.content = f"⚠️ {error}"
            self._notifier.error("Gait settings refused", str(error), client)
            return None
        key = self.solves.key(robot, settings)
        kind = "baseline (original DIRCON)" if baseline else "symmetric gait"
        running, started = self.solves.start(settings, robot, kind, key)
        if not started:  # another tab's (or this one's) solve: never cancelled silently
            waited = time.monotonic() - running.started_s
            self._notifier.error(
                "A gait solve is running",
                f"the {running.kind} (job {running.job_id}) started {waited:.0f} s ago: wait "
                "for it, or Cancel it first.",
                client,
            )
            return None
        job_id = running.job_id
        plan = (
            f" — mesh refinement: {COARSE_KNOTS} knots solved first, then {settings.knots} "
            "knots from it"
            if running.refines
            else ""
        )
        self.panel.status.content = (
            f"Solving the {kind} (job {job_id}): starting the worker and building the NLP "
            f"({settings.knots} knots) if this structure is new, then IPOPT{plan}…"
        )
        self.panel.show_running(True)
        self.worker.submit(job_id, settings, key)
        self.solves.submitted(key)
        return job_id

    def cancel(self) -> None:
        self.worker.cancel()

    def close(self) -> None:
        self.worker.close()
        self.solves.forget_structures()

    # --- events from the worker (the "solver-events" thread) ------------------------------------

    def _on_progress(self, job_id: str, iteration: int, objective: float, violation: float) -> None:
        progressed = self.solves.progress(job_id, iteration, objective, violation)
        if progressed is None:
            return
        running, history = progressed
        self.panel.show_progress(min(1.0, iteration / MAX_PROGRESS_ITERATIONS))
        if len(history[0]) % 5 == 1:
            self.panel.show_convergence(*history)
            waited = time.monotonic() - running.started_s
            restarted = ""
            if running.warm and iteration > WARM_ITERATIONS_BEFORE_FALLBACK:
                restarted = (
                    f" 🔄 The warm start did not converge in {WARM_ITERATIONS_BEFORE_FALLBACK} "
                    "iterations: restarted cold from the built-in guess."
                )
            self.panel.status.content = (
                f"Solving the {running.kind} (job {job_id}){stage_words(running, self.solves.stage)}: "
                f"IPOPT iteration {iteration}, constraint violation {violation:.1e}, "
                f"{waited:.1f} s since the click…{restarted}"
            )
            self.progressed.emit(iteration)

    def _end(
        self, job_id: str, error: str = "", result: GaitResult | None = None, forget: bool = False
    ) -> None:
        """The worker's answer to solve `job_id`; `forget`: the worker restarted (its
        structures are gone)."""
        if forget:
            self.solves.forget_structures()
        ended = self.solves.end(job_id, self._state.robot, result, error)
        if ended is None:
            return
        if ended.result is not None and ended.result.converged:
            if ended.settings.baseline:
                self.results.baseline = ended.result
            else:
                self.results.symmetric = ended.result
        self.panel.show_running(False)
        self.panel.show_convergence(*self.solves.history)
        self.panel.status.content = status_line(ended, self.results)
        self.show_results()
        pipeline, self._pipeline_job = self._pipeline_job, None
        step = self.default_step.next_step(self.planar, ended)
        if step is not None:  # the default step's walk cannot start: try a shorter one
            self.panel.show_settings(dataclasses.replace(ended.settings, step_length_m=step))
            next_job = self.solve(baseline=False)
            if next_job is not None:
                self.panel.status.content = (
                    f"{self.default_step.words()}  \n{self.panel.status.content}"
                )
                if pipeline == ended.job_id:
                    self._pipeline_job = next_job
                self.finished.emit(ended)
                return
            self.default_step.stop()
        elif (note := self.default_step.pop_note()) is not None:
            self.panel.status.content += f"  \nnote: {note}"
        if pipeline == ended.job_id and ended.result is not None and ended.result.converged:
            self.play_result(None, then=PIPELINE_STAGES)
        self.finished.emit(ended)

    # --- results -------------------------------------------------------------------------------

    def settings_changed(self) -> None:
        """Mark shown results stale when the settings no longer match them."""
        self.show_results()

    def _stale(self) -> bool:
        last = self.solves.last
        if last is None:
            return False
        try:
            return self.panel.settings(last.settings.baseline) != last.settings
        except StudioError:
            return True

    def show_results(self) -> None:
        self.panel.results.content = results_table(self.results, self._stale())
        self.panel.use.disabled = self.results.symmetric is None and self.results.baseline is None

    def pipeline(self, client: viser.ClientHandle | None = None) -> None:
        """One click: plan (unless the last gait still matches the settings) → walk → torques →
        compensation → simulation. Each stage shows its progress in its own panel."""
        fresh = self.results.symmetric is not None and not self._stale()
        if fresh:
            self.pipeline_started.emit("walking")
            self.play_result(client, then=PIPELINE_STAGES)
            return
        job_id = self.solve(baseline=False, client=client)
        if job_id is not None:
            self.pipeline_started.emit("planning")
            self._pipeline_job = job_id
            self.panel.status.content += "  \nThen: walk → torques → compensation → simulation."

    def play_result(
        self, client: viser.ClientHandle | None = None, then: tuple[str, ...] = ()
    ) -> None:
        """Walk the last good gait for the panel's number of steps (from standing to standing),
        and send the walk to playback — and so to torque feed-forward and compensation; `then`
        asks those features to run their stages on it at once."""
        result = self.results.symmetric or self.results.baseline
        robot, planar = self._state.robot, self.planar
        if result is None or robot is None or planar is None:
            return
        try:
            walk = build_walk(planar, result, steps=int(self.panel.steps.value))
        except StudioError as error:
            self.panel.status.content = f"⚠️ {error}"
            self._notifier.error("Cannot walk this gait", str(error), client)
            return
        lines = [
            f"**walk** — {walk.trajectory.duration:.2f} s, {len(walk.footprints) - 2} steps of the "
            f"planned gait on {robot.name}",
            *(f"note: {line}" for line in walk.notes),
        ]
        try:
            with self._state.lock, self._server.atomic():
                self._shown.walk = walk
                self._state.set_motion(walk.trajectory, "  \n".join(lines), robot, then)
                self._shown.show_footprints(robot, walk)
            self._state.on_play.emit(None)
        except StudioError as error:
            self._shown.walk = None
            self.panel.status.content = f"⚠️ {error}"
            self._notifier.error("Cannot play the gait", str(error), client)

    def load_planner_robot(self, client: viser.ClientHandle | None) -> Any:
        """Load the gait paper's robot into the studio; the robot, or None if it failed."""
        try:
            robot = load_robot(PAPER_ROBOT)
            report = robot_report(robot)
        except StudioError as error:
            self._notifier.error(f"Cannot load {PAPER_ROBOT}", str(error), client)
            return None
        with self._state.lock, self._server.atomic():
            self._state.set_robot(robot, report)
        return robot

    def _on_robot(self, loaded: LoadedRobot) -> None:
        """Plan for the new robot: its planar model and scaled defaults, or why not."""
        robot = loaded.robot
        self.results = GaitResults()  # gaits belong to their robot
        self.solves.last, self._shown.walk = None, None
        self.default_step.robot(None)
        self.panel.load_robot.visible = robot.name != PAPER_ROBOT
        try:
            self.planar = PlanarModel(robot)
            defaults = robot_gait_defaults(self.planar)
        except StudioError as error:
            self.planar = None
            self.panel.robot_note.content = (
                f"⚠️ The planner cannot plan for **{robot.name}**: {error}"
            )
            self.panel.show_plannable(False)
            self.show_results()
            return
        scaled = (
            "the gait paper's case"
            if robot.name == PAPER_ROBOT
            else (f"the paper's case scaled to its legs (×{defaults.length_ratio:.2f})")
        )
        lines = [
            f"Plans for **{robot.name}** ({len(self.planar.joint_names)} sagittal joints), "
            f"defaults: {scaled}."
        ]
        lines += [f"note: {note}" for note in defaults.notes]
        self.panel.robot_note.content = "  \n".join(lines)
        self.panel.show_settings(defaults.settings)
        if robot.name != PAPER_ROBOT:  # a robot-derived default step: shortened if need be
            self.default_step.robot(defaults.settings.step_length_m)
        self.panel.show_plannable(True)
        self.show_results()
        if self.worker.prepare_ahead:
            self.prepare(defaults.settings)

    def prepare(self, settings: GaitSettings) -> bool:
        """Build the loaded robot's problem for `settings`' structure in the worker, ahead of
        the first solve; False when the worker is busy (or there is no plannable robot)."""
        robot = self._state.robot
        if robot is None or self.planar is None:
            return False
        return self.worker.prepare(self.solves.key(robot, settings))
