"""Torque feed-forward and compensation in the studio: compute τ for the current motion (in a
named worker thread, with progress), keep the coefficients and the virtual servos, predict
the motion with and without compensation on every edit, and feed the ghosts and plots.

Editing a coefficient never recomputes the torques: τ depends on the plan only.
"""

from __future__ import annotations

import io
import threading
from typing import TYPE_CHECKING, Literal

import numpy as np
import viser

from app.core.dynamics.wbc import FeedForward, torque_feedforward, write_torque_csv
from app.core.errors import StudioError
from app.core.motions.trajectory import Trajectory
from app.core.posing.stance import anchor_on_foot, stance_link
from app.core.robot.model import RobotModel
from app.core.servo.compensation import CompensationParams, disabled_params
from app.core.servo.files import write_command_csv
from app.core.servo.model import Prediction, ServoModel, predict
from app.core.servo.presets import (
    TYPICAL_COMPLIANCE_DEG_PER_NM,
    paper_table2_preset,
    paper_table3_preset,
    uniform_preset,
)
from app.views.ghosts_view import GhostsView
from panels.compensation_panel import PRESETS, CompensationPanel
from panels.plots_panel import PlotsPanel

if TYPE_CHECKING:
    from app.studio import Studio


DEFAULT_BACKLASH_DEG = 0.5
"""Dead band of the default virtual servos [°] (a typical hobby servo's gear play)."""


class CompensationSession:
    def __init__(self, studio: Studio) -> None:
        self._studio = studio
        self.panel = CompensationPanel(studio.server.gui, self)
        self.plots = PlotsPanel(studio.server.gui)
        self.feedforward: FeedForward | None = None
        self.prediction: Prediction | None = None
        self.params: CompensationParams | None = None
        self.servo: ServoModel | None = None
        self.ghosts: GhostsView | None = None
        self._trajectory: Trajectory | None = None
        self._robot: RobotModel | None = None
        self._selected = ""
        self._lock = threading.Lock()
        """Guards the coefficients, servos and prediction (edits come from viser's thread pool)."""
        self._worker: threading.Thread | None = None

    # --- lifecycle ---------------------------------------------------------------------------

    def reset(self, robot: RobotModel | None, trajectory: Trajectory | None) -> None:
        """A new robot or motion: drop torques, prediction and ghosts; keep coefficients that fit."""
        with self._lock:
            if self.ghosts is not None:
                self.ghosts.remove()
            self.ghosts, self.feedforward, self.prediction = None, None, None
            self._trajectory = trajectory
            if robot is not self._robot:
                self._robot = robot
                self.params, self.servo = self._defaults(robot)
                names = robot.joint_names if robot is not None else ()
                self._selected = _first_enabled(self.params) or (names[0] if names else "")
                self.panel.show_joints(names, self._selected)
                self._show_selected()
        self.plots.clear()
        self.panel.status.content = (
            "Compute the torques of this motion."
            if trajectory is not None
            else "Generate or build a motion first."
        )

    def _defaults(
        self, robot: RobotModel | None
    ) -> tuple[CompensationParams | None, ServoModel | None]:
        """Uniform k on the legs (eq 7), and virtual servos as compliant as the paper's
        identifiable servos with a small dead band, so that compensation has work to do."""
        if robot is None:
            return None, None
        try:
            params = uniform_preset(robot)
        except StudioError:
            params = disabled_params(robot.joint_names)
        legs = params.enabled
        servo = ServoModel(
            robot.joint_names,
            np.where(legs, TYPICAL_COMPLIANCE_DEG_PER_NM, 0.0),
            np.where(legs, DEFAULT_BACKLASH_DEG, 0.0),
        )
        return params, servo

    # --- torques -----------------------------------------------------------------------------

    def compute_torques(self, client: viser.ClientHandle | None = None, wait: bool = False) -> None:
        """Start the torque feed-forward of the current motion in a worker thread."""
        studio = self._studio
        robot, trajectory = studio.robot, studio.trajectory
        if robot is None or trajectory is None:
            studio.report_error("No motion", "generate or build a motion first", client)
            return
        if self._worker is not None and self._worker.is_alive():
            return
        self.panel.show_progress(0.0)
        self.panel.status.content = (
            f"Computing τ for **{trajectory.name}** ({trajectory.n_samples} samples)…"
        )

        def work() -> None:
            try:
                result = torque_feedforward(robot, trajectory, progress=self.panel.show_progress)
            except StudioError as error:
                self.panel.show_progress(None)
                studio.report_error("Torque feed-forward failed", str(error), client)
                return
            self.panel.show_progress(None)
            if studio.robot is not robot or studio.trajectory is not trajectory:
                return  # the motion changed meanwhile: this result is stale
            with self._lock:
                self.feedforward = result
                if self.ghosts is None:
                    self.ghosts = GhostsView(studio.server, robot)
                    for name, checkbox in self.panel.ghosts.items():
                        self.ghosts.set_visible(name, checkbox.value)
            self._repredict()
            bad = result.infeasible_samples
            warning = (
                f" ⚠️ QP infeasible at {len(bad)} sample(s), first at t = {result.t[bad[0]]:.2f} s"
                if len(bad)
                else ""
            )
            self.panel.status.content = f"τ of **{trajectory.name}**: max |τ| {np.nanmax(np.abs(result.tau_Nm)):.2f} N·m.{warning}"

        self._worker = threading.Thread(target=work, name="feedforward", daemon=True)
        self._worker.start()
        if wait:
            self._worker.join()

    # --- coefficients ------------------------------------------------------------------------

    def apply_preset(self, preset: str) -> None:
        robot = self._robot
        if robot is None:
            return
        builders = {
            PRESETS[0]: lambda: uniform_preset(robot),
            PRESETS[1]: lambda: paper_table3_preset(robot),
            PRESETS[2]: lambda: paper_table3_preset(robot, clearance=True),
            PRESETS[3]: lambda: paper_table2_preset(robot),
        }
        try:
            params = (
                builders[preset]() if preset in builders else disabled_params(robot.joint_names)
            )
        except StudioError as error:
            self._studio.report_error("Preset not available", str(error), None)
            return
        with self._lock:
            self.params = params.for_joints(robot.joint_names)
        self._show_selected()
        self._repredict()

    def set_clearance_sign(self, sign: Literal["command", "torque"]) -> None:
        with self._lock:
            if self.params is None:
                return
            self.params = _replace_params(self.params, clearance_sign=sign)
        self._repredict()

    def select_joint(self, joint: str) -> None:
        self._selected = joint
        self._show_selected()

    def edit_joint(self, joint: str, field: str, value: float) -> None:
        """One value of one joint changed ("enabled", "k", "phi", "compliance", "backlash"):
        update it and re-predict (τ is unchanged)."""
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
            elif field in column:
                column[field][i] = float(value)
            else:
                raise ValueError(f"unknown coefficient {field!r}")  # a bug in the panel
            params = _replace_params(params, k_deg_per_Nm=k, phi_deg=phi, enabled=enabled)
            self.params, self.servo = params, ServoModel(servo.joint_names, compliance, backlash)
        self.panel.k_rad.content = f"k = {np.deg2rad(k[i]):.4g} rad/(N·m)"
        self._repredict()

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
            feedforward, params, servo, robot, trajectory = (
                self.feedforward,
                self.params,
                self.servo,
                self._robot,
                self._trajectory,
            )
            if (
                feedforward is None
                or params is None
                or servo is None
                or robot is None
                or trajectory is None
            ):
                return
            tau = np.nan_to_num(feedforward.tau_Nm)
            try:
                prediction = predict(robot, trajectory, tau, params, servo)
            except StudioError as error:
                self._studio.report_error("Cannot predict the motion", str(error), None)
                return
            self.prediction = prediction
        t = prediction.t
        deg = np.rad2deg
        self.plots.info.content = _attitude_summary(prediction)
        self.plots.show_torques(t, prediction.joint_names, prediction.tau_Nm)
        self.plots.show_attitude(
            t,
            [
                deg(prediction.roll_planned_rad),
                deg(prediction.pitch_planned_rad),
                deg(prediction.roll_uncompensated_rad),
                deg(prediction.pitch_uncompensated_rad),
                deg(prediction.roll_compensated_rad),
                deg(prediction.pitch_compensated_rad),
            ],
        )
        self.plots.show_offsets(
            t, prediction.joint_names, deg(prediction.q_cmd_rad - prediction.q_plan_rad)
        )
        self.show_sample(
            self._studio.trajectory.index_at(self._studio.playback_panel.time.value)
            if self._studio.trajectory is not None
            else 0
        )

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
            k = int(np.clip(k, 0, trajectory.n_samples - 1))
            planned = trajectory.q[k]
            command = robot.with_joint_angles(planned, prediction.q_cmd_rad[k])
            foot = stance_link(robot, trajectory.contacts[k])
            data = robot.model.createData()
            T_foot = robot.link_placements(planned, data)[foot]
            command = anchor_on_foot(robot, command, foot, T_foot, data)
            ghosts.update(
                {
                    "planned": planned,
                    "command": command,
                    "without": prediction.q_world_uncompensated[k],
                    "with": prediction.q_world_compensated[k],
                }
            )

    def set_ghost_visible(self, name: str, visible: bool) -> None:
        with self._lock:
            if self.ghosts is not None:
                self.ghosts.set_visible(name, visible)

    # --- files -------------------------------------------------------------------------------

    def export_commands(self, client: viser.ClientHandle | None = None) -> bytes | None:
        prediction, trajectory = self.prediction, self._trajectory
        if prediction is None or trajectory is None:
            self._studio.report_error(
                "Nothing to export", "compute the torque feed-forward first", client
            )
            return None
        buffer = io.StringIO()
        write_command_csv(buffer, prediction.t, prediction.joint_names, prediction.q_cmd_rad)
        content = buffer.getvalue().encode()
        if client is not None:
            client.send_file_download(f"{trajectory.name}_servo_commands.csv", content)
        return content

    def export_torques(self, client: viser.ClientHandle | None = None) -> bytes | None:
        feedforward = self.feedforward
        if feedforward is None:
            self._studio.report_error(
                "Nothing to export", "compute the torque feed-forward first", client
            )
            return None
        buffer = io.StringIO()
        write_torque_csv(buffer, feedforward)
        content = buffer.getvalue().encode()
        if client is not None:
            client.send_file_download(f"{feedforward.trajectory_name}_tau.csv", content)
        return content

    def remove(self) -> None:
        self.reset(None, None)


def _first_enabled(params: CompensationParams | None) -> str:
    if params is None:
        return ""
    return next((n for n, on in zip(params.joint_names, params.enabled, strict=True) if on), "")


def _replace_params(params: CompensationParams, **changes: object) -> CompensationParams:
    import dataclasses

    return dataclasses.replace(params, **changes)  # type: ignore[arg-type]


def _attitude_summary(prediction: Prediction) -> str:
    errors = prediction.attitude_errors_deg()
    return (
        "Largest torso error vs plan — "
        f"no compensation: roll {errors['roll_uncompensated']:.2f}°, pitch {errors['pitch_uncompensated']:.2f}°; "
        f"compensated: roll {errors['roll_compensated']:.2f}°, pitch {errors['pitch_compensated']:.2f}°"
    )
