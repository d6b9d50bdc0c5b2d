"""The comparison overlays: the ghosts (the plan, the command, the quick estimates and the
simulated runs, drawn at the playback time), a simulated walk's landings against the plan's
(app.views.landings_view), the Plots panel (torques, torso roll and pitch, command offsets,
the simulated lifted-foot load, with a time cursor) and the Compare panel. They draw what the state holds (its
prediction and its simulation) and keep no copy of it; their toggles are display settings kept
in projects.
"""

from __future__ import annotations

import logging

import numpy as np
import viser

from app.core.projects.display import DEFAULT_GHOSTS
from app.core.replay.pipeline import prediction_verdicts
from app.core.replay.scene import ReplayLayers
from app.core.servo.model import Prediction
from app.core.simulation.result import SimulationResult
from app.core.simulation.verdicts import LEAN_LOAD_FRACTION
from app.core.thinning import thin_minmax, thin_part
from app.studio.compare_controls import CompareControls
from app.studio.compare_text import quick_estimate_summary
from app.studio.ghost_poses import ghost_poses
from app.studio.signals import Signal
from app.studio.simulation_runner import WITH, WITHOUT, SimulationRecord
from app.studio.state import Display, Motion, StudioState
from app.studio.throttle import Throttle
from app.views.ghosts_view import GHOSTS, GhostsView
from app.views.landings_view import LandingsView
from app.views.roots import AlternatingRoot
from panels.compensation_folder import CompensationFolder
from panels.ghosts_panel import GhostsPanel
from panels.plots_panel import ATTITUDE_SERIES, SIMULATED_SERIES, PlotsPanel
from panels.quiet import set_value

log = logging.getLogger(__name__)

GRAVITY_MPS2 = 9.81
CURSOR_PERIOD_S = 0.25
"""The plots' time cursor moves at most this often during playback (each move resends the
plots' data)."""


class GhostsSession:
    """Owns the Ghosts sub-folder, the Plots and Compare panels, and the ghosts."""

    def __init__(
        self, server: viser.ViserServer, state: StudioState, folder: CompensationFolder
    ) -> None:
        self._server, self._state = server, state
        self.panel = GhostsPanel(folder, self, GHOSTS, DEFAULT_GHOSTS)
        self.plots = PlotsPanel(server.gui)
        self.view: GhostsView | None = None
        """The ghosts of the current motion, drawn once it has a quick estimate."""
        self.landings: LandingsView | None = None
        """The simulated walk's landings against the plan's (None: no walk simulated)."""
        self._landings_of: SimulationRecord | None = None
        self._landing_roots = AlternatingRoot("/landings")
        labels = {name: text for name, (_, text) in GHOSTS.items()}
        self.compare = CompareControls(
            server, state, self.panel.ghosts, labels, state.work.on_simulation, self.colour_by_error
        )
        self._roots = AlternatingRoot("/ghosts")
        self._cursor: Throttle[float] = Throttle(
            CURSOR_PERIOD_S, self._show_cursor, name="plot-cursor"
        )
        self.cursor_shown: Signal[float] = Signal("cursor_shown")
        """Emitted when the plots' time cursor has moved to a time [s]."""
        self._mirroring = False
        """A project's display settings are being shown: the widgets' echoes are not edits."""
        self._torques_thinned: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        """(times, torques, the samples their plot keeps): a slider's re-prediction keeps the
        motion and its torques (the same arrays), so their thinning is not redone."""
        self._fixed_attitude_thinned: tuple[tuple[np.ndarray, ...], int, np.ndarray] | None = None
        """(the planned and uncompensated roll and pitch, the attitude plot's curve count, the
        samples their thinning keeps): a k or φ slider changes only the compensated curves."""
        state.on_motion.connect(self._on_motion)
        state.work.on_prediction.connect(lambda _prediction: self.redraw())
        state.work.on_simulation.connect(lambda _record: self.redraw())
        state.on_time.connect(self._on_time)
        state.on_display.connect(self._on_display)
        self.plots.joints.on_update(lambda _: self._note_display())
        self.plots.wide.on_update(lambda _: self._note_display())

    # --- state changes ---------------------------------------------------------------------------

    def _on_motion(self, _motion: Motion | None) -> None:
        with self._state.lock:
            if self.view is not None:
                self.view.remove()
            self.view = None
            self._show_landings_of(None)
        self._cursor.cancel()
        self.plots.clear()

    def _on_time(self, time_s: float) -> None:
        trajectory = self._state.trajectory
        if trajectory is not None:
            self.show_sample(trajectory.index_at(time_s))
            self._cursor.submit(time_s)

    def _show_cursor(self, time_s: float) -> None:
        self.plots.show_time(time_s)
        self.cursor_shown.emit(time_s)

    # --- drawing ---------------------------------------------------------------------------------

    def redraw(self) -> None:
        """The plots and the ghosts from the state's quick estimate and simulation."""
        with self._state.lock:
            prediction, simulation = self._state.work.prediction, self._state.work.simulation
            trajectory, robot = self._state.trajectory, self._state.robot
            if prediction is None or trajectory is None or robot is None:
                return
            if self.view is None:
                self.view = self._new_view()
            simulated = simulation if _of(simulation, trajectory) else None
            self._plot(prediction, simulated)
            self._plot_lifted_load(simulated, trajectory.contacts, robot.mass_kg)
            self._show_landings_of(simulated)
            self.show_sample(trajectory.index_at(self._state.time_s))

    def _plot(self, prediction: Prediction, simulation: SimulationRecord | None) -> None:
        deg = np.rad2deg
        t = prediction.t
        self.plots.info.content = quick_estimate_summary(prediction)
        thinned = self._torques_thinned
        if thinned is None or thinned[0] is not t or thinned[1] is not prediction.tau_Nm:
            # plots get ≤ 2000 points, every peak kept
            keep = thin_minmax(t, prediction.tau_Nm.T)
            thinned = self._torques_thinned = (t, prediction.tau_Nm, keep)
        keep = thinned[2]
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
        if simulation is not None:
            runs = [simulation.run.results[WITHOUT], simulation.run.results[WITH]]
            simulated = [deg(a) for run in runs for a in (run.roll_rad, run.pitch_rad)]
            attitude = np.concatenate([attitude, np.stack(simulated)])
            labels = ATTITUDE_SERIES + SIMULATED_SERIES
        fixed = (
            prediction.roll_planned_rad,
            prediction.pitch_planned_rad,
            prediction.roll_uncompensated_rad,
            prediction.pitch_uncompensated_rad,
        )
        cached = self._fixed_attitude_thinned
        if (
            cached is None
            or cached[1] != len(attitude)
            or not all(a is b for a, b in zip(cached[0], fixed, strict=True))
        ):
            cached = (fixed, len(attitude), thin_part(t, attitude[:4], len(attitude)))
            self._fixed_attitude_thinned = cached
        keep = np.union1d(cached[2], thin_part(t, attitude[4:], len(attitude)))
        self.plots.show_attitude(
            t[keep], list(attitude[0::2, keep]), list(attitude[1::2, keep]), labels
        )
        offsets = deg(prediction.q_cmd_rad - prediction.q_plan_rad)
        keep = thin_minmax(t, offsets.T)
        self.plots.show_offsets(t[keep], prediction.joint_names, offsets[keep])

    def _plot_lifted_load(
        self, simulation: SimulationRecord | None, contacts: np.ndarray, mass_kg: float
    ) -> None:
        """The load on the feet the plan has in the air, per simulated run [% of the weight]."""
        if simulation is None:
            self.plots.drop("lifted")
            return
        runs = [simulation.run.results[WITHOUT], simulation.run.results[WITH]]
        loads = np.stack([lifted_load_percent(run, contacts, mass_kg) for run in runs])
        t = runs[0].t
        keep = thin_minmax(t, loads)
        self.plots.show_lifted_load(
            t[keep], list(loads[:, keep]), 100 * LEAN_LOAD_FRACTION, _lean_title(runs)
        )

    def _show_landings_of(self, simulation: SimulationRecord | None) -> None:
        """The landings of `simulation`'s runs that travel (drawn once per simulation)."""
        if simulation is self._landings_of:
            return
        if self.landings is not None:
            self.landings.remove()
            self.landings = None
        self._landings_of = simulation
        if simulation is None:
            return
        runs = [
            (GHOSTS[ghost][0], result.outcome.travel.footsteps)
            for ghost, label in (("sim_without", WITHOUT), ("sim_with", WITH))
            if (result := simulation.run.results[label]).outcome is not None
            and result.outcome.travel is not None
            and result.outcome.travel.footsteps  # a run that fell before landing has none
        ]
        if runs:
            self.landings = LandingsView(self._server, runs, self._landing_roots.next())
            self.landings.set_visible(bool(self.panel.landings.value))

    def show_landings(self, visible: bool) -> None:
        with self._state.lock:
            if self.landings is not None:
                self.landings.set_visible(visible)

    def show_sample(self, k: int) -> None:
        """Place the ghosts at sample k of the current motion."""
        with self._state.lock:
            state, view = self._state, self.view
            prediction, robot, trajectory = state.work.prediction, state.robot, state.trajectory
            if prediction is None or view is None or robot is None or trajectory is None:
                return
            poses = ghost_poses(robot, trajectory, prediction, state.work.simulation, k)
            with self._server.atomic():
                view.update(poses)

    def _new_view(self) -> GhostsView:
        robot = self._state.robot
        assert robot is not None
        view = GhostsView(self._server, robot, root=self._roots.next())
        for name, checkbox in self.panel.ghosts.items():
            view.set_visible(name, checkbox.value)
        view.colour_by_error(self.compare.error_ghost)
        return view

    # --- toggles (GhostsActions) -----------------------------------------------------------------

    def colour_by_error(self, name: str | None) -> None:
        """Colour ghost `name`'s links by their error from the plan (None: own colours)."""
        with self._state.lock:
            if self.view is not None:
                self.view.colour_by_error(name)

    def set_ghost_visible(self, name: str, visible: bool) -> None:
        with self._state.lock:
            if self.view is not None and name in GHOSTS:
                self.view.set_visible(name, bool(visible))
        self._note_display()

    # --- display settings (kept in projects) -----------------------------------------------------

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

    # --- replays ---------------------------------------------------------------------------------

    def replay_layers(self, traces: bool) -> ReplayLayers:
        """The ghosts shown now (checkbox on and poses to show), the key parameters and the
        verdicts, for a replay recorded as the studio shows it."""
        with self._state.lock:
            state = self._state
            prediction, coefficients = state.work.prediction, state.work.coefficients
            simulation = (
                state.work.simulation if _of(state.work.simulation, state.trajectory) else None
            )
            extra = (
                {ghost: on_plan.q for ghost, on_plan in simulation.on_plan.items()}
                if simulation is not None
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
        params = coefficients.params if coefficients is not None else None
        if params is not None and np.any(params.enabled):
            k = np.asarray(params.k_deg_per_Nm)[params.enabled]
            parameters["k"] = (
                f"{k.min():.2f}…{k.max():.2f} °/(N·m) on {int(np.sum(params.enabled))} joints"
            )
            phi = np.asarray(params.phi_deg)[params.enabled]
            if np.any(phi):
                parameters["φ"] = f"{phi.max():.1f}° ({params.clearance_sign})"
        servo = coefficients.servo if coefficients is not None else None
        if servo is not None and np.any(servo.compliance_deg_per_Nm):
            parameters["servo compliance"] = f"{np.max(servo.compliance_deg_per_Nm):.2f} °/(N·m)"
        verdicts = prediction_verdicts(prediction) if prediction is not None else ()
        if extra and simulation is not None:
            verdicts += tuple(
                f"simulated {label}: {simulation.run.results[label].verdict()}"
                for label in (WITHOUT, WITH)
            )
        return ReplayLayers(prediction, shown, extra, traces, parameters, verdicts)

    def close(self) -> None:
        self._cursor.cancel()


def lifted_load_percent(run: SimulationResult, contacts: np.ndarray, mass_kg: float) -> np.ndarray:
    """Largest vertical floor force on a sole the plan has in the air, over the weight [%],
    shape (T,) (the verdict's lean measure, app.core.simulation.verdicts)."""
    load = run.contact_force_N[:, :, 2] / (mass_kg * GRAVITY_MPS2)
    return 100.0 * np.where(np.asarray(contacts, dtype=bool), 0.0, load).max(axis=1)


def _lean_title(runs: list[SimulationResult]) -> str:
    """The lifted-foot load plot's title: when each run leaned, or its scuffs."""
    parts = []
    for name, run in zip(("no comp.", "comp."), runs, strict=True):
        verdict = run.outcome
        if verdict is None:
            continue
        if verdict.lean is not None:
            parts.append(
                f"{name} leans from {verdict.lean.start_s:.2f} s "
                f"({verdict.lifted_foot_load_s:.2f} s in all)"
            )
        elif verdict.scuffs:
            count = len(verdict.scuffs)
            parts.append(
                f"{name} {count} scuff{'s' if count > 1 else ''} from "
                f"{verdict.scuffs[0].start_s:.2f} s"
            )
        else:
            parts.append(f"{name} no lean")
    return "Lifted-foot load [% of weight]" + (f": {'; '.join(parts)}" if parts else "")


def _of(simulation: SimulationRecord | None, trajectory: object) -> bool:
    """The simulation is of that motion."""
    return simulation is not None and simulation.run.trajectory is trajectory
