"""Torque feed-forward and compensation in the studio: compute τ for the current motion (in a
named worker thread, with progress, over a warm pool of worker processes on every core: started
by the first computation long enough to pay for it (MIN_POOL_SAMPLES; a shorter motion is solved
in the thread, same torques), kept for the next ones, closed with the studio), keep the coefficients and the virtual servos, predict the
motion with and without compensation on every edit, and drive the ghosts and plots.

Editing a coefficient never recomputes the torques: τ depends on the plan only. Edits from
several tabs are coalesced like drags: a prediction that has not started yet is replaced by
the newest one.
"""

from __future__ import annotations

import dataclasses
import io
import logging
import math
import threading

import numpy as np
import viser

from app.core.dynamics.parallel import MIN_POOL_SAMPLES, FeedForwardPool
from app.core.dynamics.peaks import TorquePeaks, torque_peaks
from app.core.dynamics.wbc import FeedForward, torque_feedforward
from app.core.errors import StudioError
from app.core.motions.trajectory import Trajectory
from app.core.papers import TYPICAL_COMPLIANCE_DEG_PER_NM
from app.core.projects.display import DEFAULT_GHOSTS
from app.core.projects.project import Project
from app.core.replay.pipeline import prediction_verdicts
from app.core.replay.scene import ReplayLayers
from app.core.robot.model import RobotModel
from app.core.servo.compensation import (
    CLEARANCE_SIGNS,
    MAX_ABS_K_DEG_PER_NM,
    MAX_PHI_DEG,
    CompensationParams,
    disabled_params,
)
from app.core.servo.files import write_command_csv, write_torque_csv
from app.core.servo.model import (
    Prediction,
    Predictor,
    ServoModel,
    joint_angles,
)
from app.core.servo.preset_safety import implausible_prediction, scaled_to_limits
from app.core.servo.presets import PRESETS, preset_params
from app.core.simulation.files import DEFAULT_BACKLASH_DEG
from app.core.simulation.result import SimulationResult
from app.core.simulation.worker import SimulationJob
from app.core.thinning import thin_minmax
from app.studio.coalesce import Coalescer
from app.studio.compare_controls import CompareControls
from app.studio.compare_text import quick_estimate_summary, simulation_summary
from app.studio.ghost_poses import GhostPoses
from app.studio.notifier import Notifier
from app.studio.signals import Signal
from app.studio.simulation_runner import WITH, WITHOUT, Simulation, SimulationRunner
from app.studio.state import Display, LoadedRobot, Motion, StudioState
from app.studio.throttle import Throttle
from app.views.ghosts_view import GHOSTS, GhostsView
from app.views.roots import AlternatingRoot
from panels.compensation_panel import CompensationPanel
from panels.plots_panel import ATTITUDE_SERIES, SIMULATED_SERIES, PlotsPanel
from panels.quiet import set_value

log = logging.getLogger(__name__)

CURSOR_PERIOD_S = 0.25
"""The plots' time cursor moves at most this often during playback (each move resends the
plots' data)."""

DEFAULT_PRESET = next(iter(PRESETS))
MAX_BACKLASH_DEG = 20.0
FIELD_RANGES = {
    "k": (-MAX_ABS_K_DEG_PER_NM, MAX_ABS_K_DEG_PER_NM),
    "phi": (0.0, MAX_PHI_DEG),
    "compliance": (-MAX_ABS_K_DEG_PER_NM, MAX_ABS_K_DEG_PER_NM),
    "backlash": (0.0, MAX_BACKLASH_DEG),
    "enabled": (0.0, 1.0),
}
"""What each per-joint value may be, re-checked on arrival (a crafted client can send any)."""


class CompensationSession:
    """Owns the Compensation and Plots panels and the ghosts."""

    def __init__(self, server: viser.ViserServer, state: StudioState, notifier: Notifier) -> None:
        self._server, self._state, self._notifier = server, state, notifier
        self.panel = CompensationPanel(server.gui, self, GHOSTS, DEFAULT_GHOSTS)
        self.plots = PlotsPanel(server.gui)
        self.feedforward: FeedForward | None = None
        self.prediction: Prediction | None = None
        self.params: CompensationParams | None = None
        self.servo: ServoModel | None = None
        self.ghosts: GhostsView | None = None
        self.torques_done: Signal[FeedForward | None] = Signal("torques_done")
        """Emitted when a torque computation ends: its result, or None if it failed or was
        dropped because the motion changed meanwhile."""
        self._robot: RobotModel | None = None
        self._trajectory: Trajectory | None = None
        self._selected = ""
        self._lock = threading.Lock()
        """Guards coefficients, servos, torques and prediction (edits come from viser's pool)."""
        self._worker: threading.Thread | None = None
        self._pool: FeedForwardPool | None = None
        self.pool_min_samples = MIN_POOL_SAMPLES
        """Motions with fewer samples are solved in the thread, without the pool."""
        """The feed-forward's worker processes, started by the first computation."""
        self._pool_lock = threading.Lock()
        self._closed = False
        self._predictions: Coalescer[str, None] = Coalescer(lambda _key, _value: self._repredict())
        self._then: tuple[str, ...] = ()
        """Stages the current motion asked for (the one-click pipeline), not yet run."""
        self._predictor: Predictor | None = None
        """The current motion's and torques' predictor: what the coefficients do not change,
        computed once per motion and τ."""
        self._predictor_for: FeedForward | None = None
        self.simulation: Simulation | None = None
        """The last good simulation of the current motion (physics, app.core.simulation)."""
        self.simulation_stale = False
        """The coefficients or servos changed since `simulation` ran."""
        self.runner = SimulationRunner(self._on_simulation_progress)
        self.runner.finished.connect(self._on_simulated)
        labels = {name: text for name, (_, text) in GHOSTS.items()}
        self.compare = CompareControls(
            server, state, self.panel.ghosts, labels, self.runner.finished, self.colour_by_error
        )
        self._roots = AlternatingRoot("/ghosts")
        self._poses = GhostPoses()
        self._cursor: Throttle[float] = Throttle(
            CURSOR_PERIOD_S, self._show_cursor, name="plot-cursor"
        )
        self.cursor_shown: Signal[float] = Signal("cursor_shown")
        """Emitted when the plots' time cursor has moved to a time [s]."""
        state.on_robot.connect(self._on_robot)
        state.on_motion.connect(self._on_motion)
        state.on_time.connect(self._on_time)
        state.on_display.connect(self._on_display)
        self._mirroring = False
        """A project's display settings are being shown: the widgets' echoes are not edits."""
        self.plots.joints.on_update(lambda _: self._note_display())
        self.plots.wide.on_update(lambda _: self._note_display())

    # --- projects (HoldsWork) -------------------------------------------------------------------

    def snapshot(self) -> dict[str, object]:
        with self._lock:
            simulation, trajectory = self.simulation, self._trajectory
            runs: tuple[SimulationResult, ...] = ()
            if simulation is not None and simulation.trajectory is trajectory:
                runs = (simulation.results[WITHOUT], simulation.results[WITH])
            return {
                "feedforward": self.feedforward,
                "compensation": self.params,
                "servo": self.servo,
                "simulation": runs,
                "simulation_stale": self.simulation_stale if runs else False,
                "simulation_wall_s": simulation.waited_s
                if runs and simulation is not None
                else None,
            }

    def restore(self, project: Project) -> None:
        """The project's coefficients, servos, torques (ghosts and plots follow) and last
        simulation; called once its robot and motion are installed."""
        robot, trajectory = self._robot, self._trajectory
        with self._lock:
            if project.compensation is not None:
                self.params = project.compensation
            if project.servo is not None:
                self.servo = project.servo
        self._show_selected()
        feedforward = project.feedforward
        if feedforward is None or robot is None or trajectory is None:
            return
        with self._lock:
            self.feedforward = feedforward
            if self.ghosts is None:
                self.ghosts = self._new_ghosts(robot)
            if len(project.simulation) == 2:
                without, with_ = project.simulation
                self.simulation = Simulation(
                    job_id="project",
                    robot=robot,
                    trajectory=trajectory,
                    job=SimulationJob((), ()),
                    started_s=0.0,
                    results={WITHOUT: without, WITH: with_},
                    waited_s=project.simulation_wall_s,
                )
        self._repredict()
        self.panel.status.content = _torque_summary(
            torque_peaks(robot, trajectory, feedforward), trajectory
        )
        if self.simulation is not None:
            self.panel.verdict.content = self._simulation_text(self.simulation)
            if project.simulation_stale:
                self._mark_simulation_stale()

    # --- state changes ------------------------------------------------------------------------

    def _on_robot(self, loaded: LoadedRobot) -> None:
        robot = loaded.robot
        params, servo = default_params(robot)
        with self._lock:
            self._robot, self.params, self.servo = robot, params, servo
            self._selected = _first_enabled(params) or (
                robot.joint_names[0] if robot.n_actuated else ""
            )
        self.panel.show_joints(robot.joint_names, self._selected)
        self._show_selected()

    def _on_motion(self, motion: Motion | None) -> None:
        with self._lock:
            if self.ghosts is not None:
                self.ghosts.remove()
            self.ghosts, self.feedforward, self.prediction = None, None, None
            self.simulation, self.simulation_stale = None, False
            self._trajectory = motion.trajectory if motion is not None else None
        self.panel.verdict.content = "Compute the torques, then simulate: the verdict appears here."
        self._then = motion.then if motion is not None else ()
        if "torques" in self._then:  # the one-click pipeline: torques, then maybe simulation
            self.compute_torques()
        self._cursor.cancel()
        self.plots.clear()
        self.panel.status.content = (
            "Compute the torques of this motion."
            if motion is not None
            else "Generate or build a motion first."
        )

    def _on_time(self, time_s: float) -> None:
        trajectory = self._trajectory
        if trajectory is not None:
            self.show_sample(trajectory.index_at(time_s))
            self._cursor.submit(time_s)

    def _show_cursor(self, time_s: float) -> None:
        self.plots.show_time(time_s)
        self.cursor_shown.emit(time_s)

    # --- torques -----------------------------------------------------------------------------

    def compute_torques(self, client: viser.ClientHandle | None = None) -> None:
        """Start the torque feed-forward of the current motion in a worker thread; the result
        is announced by `torques_done`."""
        with self._state.lock:
            robot, trajectory = self._state.robot, self._state.trajectory
        if robot is None or trajectory is None:
            self._fail("No motion", "generate or build a motion first", client)
            return
        if self._worker is not None and self._worker.is_alive():
            return
        self.panel.show_progress(0.0)
        self.panel.status.content = (
            f"Computing τ for **{trajectory.name}** ({trajectory.n_samples} samples)…"
        )
        self._worker = threading.Thread(
            target=self._compute, args=(robot, trajectory, client), name="feedforward", daemon=True
        )
        self._worker.start()

    def _compute(
        self, robot: RobotModel, trajectory: Trajectory, client: viser.ClientHandle | None
    ) -> None:
        result: FeedForward | None = None
        try:
            pool = self._warm_pool() if trajectory.n_samples >= self.pool_min_samples else None
            result = torque_feedforward(
                robot, trajectory, progress=self.panel.show_progress, pool=pool
            )
            self._accept(robot, trajectory, result)
        except StudioError as error:
            result = None
            self._fail("Torque feed-forward failed", str(error), client)
        except Exception as error:  # a bug: say so in the panel, and still announce the end
            log.exception("torque feed-forward")
            result = None
            self._fail("Torque feed-forward failed", f"{type(error).__name__}: {error}", client)
        finally:
            self.panel.show_progress(None)
            self.torques_done.emit(result if result is self.feedforward else None)

    def _accept(self, robot: RobotModel, trajectory: Trajectory, result: FeedForward) -> None:
        """Keep a computed τ if the motion is still the one it was computed for; predict."""
        with self._lock:
            if self._robot is not robot or self._trajectory is not trajectory:
                return  # the motion changed meanwhile: this result is stale
            self.feedforward = result
            if self.ghosts is None:
                self.ghosts = self._new_ghosts(robot)
        self._repredict()
        self.panel.status.content = _torque_summary(
            torque_peaks(robot, trajectory, result), trajectory
        )
        if "simulate" in self._then:  # the one-click pipeline's last stage
            self._then = ()
            self.simulate()
        else:
            self.runner.warm_up()  # a Simulate click next should not wait for a process to spawn

    # --- coefficients (CompensationActions) -----------------------------------------------------

    def apply_preset(self, key: str) -> None:
        robot = self._robot
        if robot is None:
            return
        try:
            params = preset_params(key, robot)
        except StudioError as error:
            self._fail("Preset not available", str(error), None)
            return
        feedforward, trajectory = self.feedforward, self._trajectory
        if feedforward is not None and trajectory is not None:
            lower = np.array([j.lower for j in robot.joints])
            upper = np.array([j.upper for j in robot.joints])
            params, scale = scaled_to_limits(
                params,
                joint_angles(robot, trajectory.q),
                np.nan_to_num(feedforward.tau_Nm),
                lower,
                upper,
            )
            if scale < 1.0:
                self.panel.status.content = f"⚠️ {params.notes[-1]}"
                self._notifier.notify("Preset scaled", params.notes[-1], None, "yellow")
        with self._lock:
            self.params = params
        self._show_selected()
        self._mark_simulation_stale()
        self._predictions.submit("predict", None)

    def set_servos(self, params: CompensationParams, servo: ServoModel) -> None:
        """Take coefficients and virtual servos made elsewhere (a sweep point's servo settings)
        for the loaded robot; ones for other joints are refused, keeping the current ones."""
        robot = self._robot
        if robot is None or not robot.joint_names == params.joint_names == servo.joint_names:
            self._fail("Servo settings refused", "they are for another robot's joints", None)
            return
        with self._lock:
            self.params, self.servo = params, servo
            if self._selected not in robot.joint_names or not params.enabled.any():
                self._selected = _first_enabled(params) or self._selected
        self.panel.show_joints(robot.joint_names, self._selected)
        self._show_selected()
        self._mark_simulation_stale()
        self._predictions.submit("predict", None)

    def set_clearance_sign(self, sign: str) -> None:
        if sign not in CLEARANCE_SIGNS:
            return
        with self._lock:
            if self.params is None:
                return
            self.params = dataclasses.replace(self.params, clearance_sign=sign)  # type: ignore[arg-type]
        self._mark_simulation_stale()
        self._predictions.submit("predict", None)

    def select_joint(self, joint: str) -> None:
        self._selected = joint
        self._show_selected()

    def edit_joint(self, joint: str, field: str, value: float) -> None:
        """One value of one joint changed ("enabled", "k", "phi", "compliance", "backlash"):
        check it, update it and re-predict (τ is unchanged)."""
        low, high = FIELD_RANGES.get(field, (math.nan, math.nan))
        if not (isinstance(value, int | float) and low <= float(value) <= high):
            self._fail(
                "Value refused", f"{field} = {value!r}: give a value in [{low:g}, {high:g}]", None
            )
            self._show_selected()
            return
        with self._lock:
            params, servo = self.params, self.servo
            if params is None or servo is None or joint not in params.joint_names:
                return
            i = params.joint_names.index(joint)
            k, phi, enabled = (
                params.k_deg_per_Nm.copy(),
                params.phi_deg.copy(),
                params.enabled.copy(),
            )
            compliance, backlash = servo.compliance_deg_per_Nm.copy(), servo.backlash_deg.copy()
            column = {"k": k, "phi": phi, "compliance": compliance, "backlash": backlash}
            if field == "enabled":
                enabled[i] = bool(value)
            else:
                column[field][i] = float(value)
            self.params = dataclasses.replace(params, k_deg_per_Nm=k, phi_deg=phi, enabled=enabled)
            self.servo = ServoModel(servo.joint_names, compliance, backlash)
        if joint == self._selected:
            self._show_selected()
        self._mark_simulation_stale()
        self._predictions.submit("predict", None)

    def _show_selected(self) -> None:
        params, servo = self.params, self.servo
        if params is None or servo is None or self._selected not in params.joint_names:
            return
        i = params.joint_names.index(self._selected)
        self.panel.show_joint(
            bool(params.enabled[i]),
            float(params.k_deg_per_Nm[i]),
            float(params.phi_deg[i]),
            float(servo.compliance_deg_per_Nm[i]),
            float(servo.backlash_deg[i]),
        )

    # --- prediction, ghosts, plots -----------------------------------------------------------

    def _repredict(self) -> None:
        with self._lock:
            feedforward, params, servo = self.feedforward, self.params, self.servo
            robot, trajectory = self._robot, self._trajectory
            if None in (feedforward, params, servo, robot, trajectory):
                return
            assert feedforward is not None and params is not None and servo is not None
            assert robot is not None and trajectory is not None
            try:
                predictor = self._predictor
                if (
                    predictor is None
                    or predictor.trajectory is not trajectory
                    or self._predictor_for is not feedforward
                ):
                    predictor = Predictor(robot, trajectory, np.nan_to_num(feedforward.tau_Nm))
                    self._predictor = predictor
                    self._predictor_for = feedforward
                prediction = predictor.predict(params, servo)
            except StudioError as error:
                self._fail("Cannot predict the motion", str(error), None)
                return
            self.prediction = prediction
        absurd = implausible_prediction(prediction)
        if absurd:
            self.panel.status.content = "⚠️ " + "; ".join(absurd) + " (quick estimate)"
        deg = np.rad2deg
        t = prediction.t
        self.plots.info.content = quick_estimate_summary(prediction)
        keep = thin_minmax(t, prediction.tau_Nm.T)  # plots get ≤ 2000 points, every peak kept
        self.plots.show_torques(t[keep], prediction.joint_names, prediction.tau_Nm[keep])
        attitude = np.stack(
            [
                deg(prediction.roll_planned_rad),
                deg(prediction.pitch_planned_rad),
                deg(prediction.roll_uncompensated_rad),
                deg(prediction.pitch_uncompensated_rad),
                deg(prediction.roll_compensated_rad),
                deg(prediction.pitch_compensated_rad),
            ]
        )
        labels: tuple[tuple[str, str, tuple[float, ...]], ...] = ATTITUDE_SERIES
        simulation = self.simulation
        if simulation is not None and simulation.trajectory is trajectory:
            runs = [simulation.results[WITHOUT], simulation.results[WITH]]
            simulated = [deg(a) for run in runs for a in (run.roll_rad, run.pitch_rad)]
            attitude = np.concatenate([attitude, np.stack(simulated)])
            labels = ATTITUDE_SERIES + SIMULATED_SERIES
        keep = thin_minmax(t, attitude)
        self.plots.show_attitude(
            t[keep], list(attitude[0::2, keep]), list(attitude[1::2, keep]), labels
        )
        offsets = deg(prediction.q_cmd_rad - prediction.q_plan_rad)
        keep = thin_minmax(t, offsets.T)
        self.plots.show_offsets(t[keep], prediction.joint_names, offsets[keep])
        self.show_sample(trajectory.index_at(self._state.time_s))

    def show_sample(self, k: int) -> None:
        """Place the ghosts at sample k of the current motion."""
        with self._lock:
            prediction, ghosts, robot, trajectory = (
                self.prediction,
                self.ghosts,
                self._robot,
                self._trajectory,
            )
            if prediction is None or ghosts is None or robot is None or trajectory is None:
                return
            poses = self._poses.at(robot, trajectory, prediction, self.simulation, k)
            with self._server.atomic():
                ghosts.update(poses)

    def _new_ghosts(self, robot: RobotModel) -> GhostsView:
        ghosts = GhostsView(self._server, robot, root=self._roots.next())
        for name, checkbox in self.panel.ghosts.items():
            ghosts.set_visible(name, checkbox.value)
        ghosts.colour_by_error(self.compare.error_ghost)
        return ghosts

    def colour_by_error(self, name: str | None) -> None:
        """Colour ghost `name`'s links by their error from the plan (None: own colours)."""
        with self._lock:
            if self.ghosts is not None:
                self.ghosts.colour_by_error(name)

    def set_ghost_visible(self, name: str, visible: bool) -> None:
        with self._lock:
            if self.ghosts is not None and name in GHOSTS:
                self.ghosts.set_visible(name, bool(visible))
        self._note_display()

    # --- display settings (kept in projects) ----------------------------------------------------

    def _note_display(self) -> None:
        """The ghosts shown and the plots' choices into the state's display settings."""
        with self._state.lock:
            if self._mirroring:
                return
            self._state.set_display(
                "panel",
                ghosts=tuple(name for name, box in self.panel.ghosts.items() if box.value),
                plot_joints=str(self.plots.joints.value),
                wide_plots=bool(self.plots.wide.value),
            )

    def _on_display(self, display: Display) -> None:
        """An opened project's ghosts and plot choices: the checkboxes, ghosts and plots follow."""
        if display.origin != "project":
            return
        settings = display.settings
        with self._state.lock:
            self._mirroring = True
            try:
                for name, box in self.panel.ghosts.items():
                    set_value(box, name in settings.ghosts)  # the ghosts follow their box
                shown = settings.plot_joints in self.plots.joints.options
                if shown:
                    set_value(self.plots.joints, settings.plot_joints)
                set_value(self.plots.wide, settings.wide_plots)
            finally:
                self._mirroring = False
            if not shown:  # no torques yet to offer that choice: keep what the panel shows
                self._note_display()

    # --- simulation (physics) ---------------------------------------------------------------

    def simulate(self, client: viser.ClientHandle | None = None) -> None:
        """Simulate the plan and the compensated commands on MuJoCo in the worker process;
        the end is announced by `runner.finished`."""
        with self._lock:
            robot, trajectory, prediction, servo = (
                self._robot,
                self._trajectory,
                self.prediction,
                self.servo,
            )
        if robot is None or trajectory is None or prediction is None or servo is None:
            self._fail("Nothing to simulate", "compute the torque feed-forward first", client)
            return
        if self.runner.running is not None:
            return
        try:
            self.runner.start(robot, trajectory, prediction.q_plan_rad, prediction.q_cmd_rad, servo)
        except (OSError, RuntimeError) as error:  # the worker process could not start
            self._fail("Cannot simulate", f"the simulation worker did not start: {error}", client)
            return
        except StudioError as error:
            self.panel.verdict.content = f"⚠️ {error}"
            self._notifier.error("Cannot simulate", str(error), client)
            return
        self.panel.show_simulating(0.0)
        self.panel.verdict.content = (
            f"Simulating **{trajectory.name}** without and with compensation "
            f"({trajectory.duration:.1f} s each)…"
        )

    def cancel_simulation(self) -> None:
        self.runner.cancel()

    def _on_simulation_progress(self, fraction: float) -> None:
        if self.runner.running is not None:
            self.panel.show_simulating(fraction)

    def _on_simulated(self, simulation: Simulation) -> None:
        self.panel.show_simulating(None)
        kept = " The last good simulation is kept." if self.simulation is not None else ""
        if simulation.error == "cancelled":
            self.panel.verdict.content = "Simulation cancelled." + kept
            return
        if simulation.error:
            self.panel.verdict.content = f"⚠️ Simulation failed: {simulation.error}.{kept}"
            self._notifier.error("Simulation failed", simulation.error)
            return
        with self._lock:
            if simulation.trajectory is not self._trajectory:
                return  # the motion changed meanwhile
            self.simulation, self.simulation_stale = simulation, False
        self.panel.verdict.content = self._simulation_text(simulation)
        self._repredict()

    def _mark_simulation_stale(self) -> None:
        if self.simulation is not None and not self.simulation_stale:
            self.simulation_stale = True
            self.panel.verdict.content = (
                "⚠️ Stale: the coefficients or servos changed since this simulation; simulate "
                "again.  \n" + self._simulation_text(self.simulation)
            )

    def _simulation_text(self, simulation: Simulation) -> str:
        robot = self._robot
        drift = self._poses.drift_m(robot, simulation) if robot is not None else None
        return simulation_summary(simulation, drift)

    def replay_layers(self, traces: bool) -> ReplayLayers:
        """The ghosts shown now (checkbox on and poses to show), the key parameters and the
        verdicts, for a replay recorded as the studio shows it."""
        with self._lock:
            prediction, params, servo = self.prediction, self.params, self.servo
            simulation, trajectory = self.simulation, self._trajectory
            fresh = simulation is not None and simulation.trajectory is trajectory
            robot = self._robot
            extra = (
                {g: on_plan.q for g, on_plan in self._poses.simulated(robot, simulation).items()}
                if fresh and simulation is not None and robot is not None and not simulation.error
                else {}
            )
            shown = tuple(
                name
                for name, checkbox in self.panel.ghosts.items()
                if checkbox.value
                and (
                    name in extra
                    or (prediction is not None and name not in ("sim_without", "sim_with"))
                )
            )
        parameters: dict[str, str] = {}
        if params is not None and np.any(params.enabled):
            k = np.asarray(params.k_deg_per_Nm)[params.enabled]
            parameters["k"] = (
                f"{k.min():.2f}…{k.max():.2f} °/(N·m) on {int(np.sum(params.enabled))} joints"
            )
            phi = np.asarray(params.phi_deg)[params.enabled]
            if np.any(phi):
                parameters["φ"] = f"{phi.max():.1f}° ({params.clearance_sign})"
        if servo is not None and np.any(servo.compliance_deg_per_Nm):
            parameters["servo compliance"] = f"{np.max(servo.compliance_deg_per_Nm):.2f} °/(N·m)"
        verdicts = prediction_verdicts(prediction) if prediction is not None else ()
        if extra and simulation is not None:
            verdicts += tuple(
                f"simulated {label}: {simulation.results[label].verdict()}"
                for label in (WITHOUT, WITH)
            )
        return ReplayLayers(prediction, shown, extra, traces, parameters, verdicts)

    @property
    def feedforward_pool(self) -> FeedForwardPool | None:
        """The warm worker pool of the torque feed-forward, None before the first use."""
        return self._pool

    def _warm_pool(self) -> FeedForwardPool:
        """The studio's pool of feed-forward workers (one per core), started on first use."""
        with self._pool_lock:
            if self._closed:
                raise StudioError("the studio is shutting down")
            if self._pool is None:
                self._pool = FeedForwardPool()
            return self._pool

    def close(self) -> None:
        self._cursor.cancel()
        self.runner.close()
        with self._pool_lock:
            self._closed = True
            pool, self._pool = self._pool, None
        if pool is not None:
            pool.close()

    # --- files -------------------------------------------------------------------------------

    def export_commands(self, client: viser.ClientHandle | None = None) -> bytes | None:
        prediction, trajectory = self.prediction, self._trajectory
        if prediction is None or trajectory is None:
            self._fail("Nothing to export", "compute the torque feed-forward first", client)
            return None
        robot = self._robot
        assert robot is not None
        buffer = io.StringIO()
        try:
            write_command_csv(
                buffer,
                prediction.t,
                prediction.joint_names,
                prediction.q_cmd_rad,
                np.array([j.lower for j in robot.joints]),
                np.array([j.upper for j in robot.joints]),
            )
        except StudioError as error:  # a command file for real servos is never written wrong
            self._fail("Commands not exported", str(error), client)
            return None
        content = buffer.getvalue().encode()
        if client is not None:
            client.send_file_download(f"{trajectory.name}_servo_commands.csv", content)
        return content

    def export_torques(self, client: viser.ClientHandle | None = None) -> bytes | None:
        feedforward = self.feedforward
        if feedforward is None:
            self._fail("Nothing to export", "compute the torque feed-forward first", client)
            return None
        buffer = io.StringIO()
        write_torque_csv(buffer, feedforward)
        content = buffer.getvalue().encode()
        if client is not None:
            client.send_file_download(f"{feedforward.trajectory_name}_tau.csv", content)
        return content

    def _fail(self, title: str, body: str, client: viser.ClientHandle | None) -> None:
        self.panel.status.content = f"⚠️ {body}"
        self._notifier.error(title, body, client)


def default_params(robot: RobotModel) -> tuple[CompensationParams, ServoModel]:
    """The default preset on the robot (no compensation where it does not fit), and virtual
    servos as compliant as the paper's identifiable servos with a small dead band on the
    compensated joints, so that compensation has work to do."""
    try:
        params = preset_params(DEFAULT_PRESET, robot)
    except StudioError:
        params = disabled_params(robot.joint_names)
    legs = params.enabled
    servo = ServoModel(
        robot.joint_names,
        np.where(legs, TYPICAL_COMPLIANCE_DEG_PER_NM, 0.0),
        np.where(legs, DEFAULT_BACKLASH_DEG, 0.0),
    )
    return params, servo


def _first_enabled(params: CompensationParams) -> str:
    return next((n for n, on in zip(params.joint_names, params.enabled, strict=True) if on), "")


def _torque_summary(peaks: TorquePeaks, trajectory: Trajectory) -> str:
    """Peak torque over the samples the QP and the joints' speed limits can follow; flagged
    samples named apart (their torques are not peaks: the robot cannot do them)."""
    worst = int(np.argmax(peaks.max_abs_tau_Nm)) if len(peaks.joint_names) else 0
    lines = [
        f"τ of **{trajectory.name}**: max |τ| {peaks.max_abs_tau_Nm[worst]:.2f} N·m "
        f"({peaks.joint_names[worst]}) over the samples the robot can follow."
    ]
    for what, samples in (
        ("the whole-body QP cannot follow", peaks.infeasible_samples),
        ("ask a joint to move faster than its limit", peaks.over_speed_samples),
    ):
        if samples:
            first = trajectory.t[samples[0]]
            lines.append(
                f"⚠️ **{len(samples)} sample(s) {what}** (first at t = {first:.2f} s); their "
                "torques are left out of the peak."
            )
    if peaks.flagged_samples:
        everything = float(np.max(peaks.max_abs_tau_all_samples_Nm))
        lines.append(f"Peak over every sample, flagged ones included: {everything:.2f} N·m.")
    return "  \n".join(lines)
