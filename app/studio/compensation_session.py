"""Compensation in the studio: the coefficients (eq 7, eq 23) and the virtual servos, their
presets and typed per-joint edits, the torque eq 7 multiplies (the servos' drive torque by
default, with the D and J of the servo law the simulation runs: app.core.simulation.drive, as
`simulate --drive-torque`), the quick estimate of the motion with and without compensation
(its commands are the ones simulated), and the servo command file.

Coefficients, servos and the estimate live in the state (`StudioState.set_coefficients`,
`set_prediction`); this session re-predicts when the torques or the coefficients change.
Edits from several tabs are coalesced like drags: an estimate that has not started yet is
replaced by the newest one.
"""

from __future__ import annotations

import dataclasses
import io
import logging

import numpy as np
import viser

from app.core.dynamics.peaks import torque_peaks
from app.core.dynamics.wbc import FeedForward
from app.core.errors import StudioError
from app.core.motions.trajectory import Trajectory
from app.core.robot.model import RobotModel
from app.core.servo.compensation import CLEARANCE_SIGNS, CompensationParams, disabled_params
from app.core.servo.edits import JointEdit
from app.core.servo.files import write_command_csv
from app.core.servo.model import ServoModel, joint_angles
from app.core.servo.predictor import Predictor
from app.core.servo.preset_safety import implausible_prediction, scaled_to_limits
from app.core.servo.presets import PRESETS, preset_params
from app.core.servo.scaling import scaled_servo_model
from app.core.simulation.drive import COMPENSATED_TORQUES, compensated_torque_Nm
from app.studio.coalesce import Coalescer
from app.studio.file_names import file_slug
from app.studio.notifier import Notifier
from app.studio.servo_parts import simulation_law
from app.studio.state import LoadedRobot, StudioState
from app.studio.torque_text import torque_summary
from app.studio.work import Coefficients
from panels.compensation_folder import CompensationFolder
from panels.compensation_panel import CompensationPanel

log = logging.getLogger(__name__)

DEFAULT_PRESET = next(iter(PRESETS))


class CompensationSession:
    """Owns the coefficients' rows of the Compensation folder and the quick estimate."""

    def __init__(self, state: StudioState, notifier: Notifier, folder: CompensationFolder) -> None:
        self._state, self._notifier = state, notifier
        self.panel = CompensationPanel(folder, self)
        self._selected = ""
        """The joint the per-joint controls show."""
        self._predictions: Coalescer[str, None] = Coalescer(lambda _key, _value: self.predict())
        self._predictor: tuple[FeedForward, np.ndarray, Predictor] | None = None
        """The current torques, the torque compensated and its predictor: what the coefficients
        do not change, computed once per motion and compensated torque."""
        self._torque: tuple[tuple[object, ...], str, ServoModel, np.ndarray] | None = None
        self._warned = ""
        """The warning this session last put in the status (a preset scaled, an absurd quick
        estimate): taken back, for the torques' summary, once it no longer holds."""
        """What the compensated torque was computed from (robot, motion, torques and parts,
        torque kind, servos) and the torque (`_compensated_torque`)."""
        state.on_robot.connect(self._on_robot)
        state.work.on_coefficients.connect(self._on_coefficients)
        state.work.on_torques.connect(lambda _torques: self.predict())
        # servo parts change the drive torque's D and J (set after their coefficients)
        state.work.on_parts.connect(lambda _choice: self._predictions.submit("predict", None))

    def _on_robot(self, loaded: LoadedRobot) -> None:
        robot = loaded.robot
        params, servo = default_params(robot)
        self._selected = _first_enabled(params) or (
            robot.joint_names[0] if robot.n_actuated else ""
        )
        self.panel.show_joints(robot.joint_names, self._selected)
        self._state.work.set_coefficients(params, servo, "robot")

    def _on_coefficients(self, coefficients: Coefficients) -> None:
        self.panel.show_compensated_torque(coefficients.torque)
        self._show_selected()
        self._predictions.submit("predict", None)

    # --- coefficients (CompensationActions) -----------------------------------------------------

    def apply_preset(self, key: str) -> None:
        robot = self._state.robot
        current = self._state.work.coefficients
        if robot is None or current is None:
            return
        try:
            params = preset_params(key, robot)
        except StudioError as error:
            self._fail("Preset not available", str(error), None)
            return
        feedforward, trajectory = self._state.work.torques, self._state.trajectory
        if feedforward is not None and trajectory is not None:
            lower = np.array([j.lower for j in robot.joints])
            upper = np.array([j.upper for j in robot.joints])
            try:  # scaled on the torque it will multiply (the drive torque by default)
                tau_Nm = self._compensated_torque(robot, trajectory, feedforward, current)
            except StudioError as error:
                self._fail("Preset not available", str(error), None)
                return
            params, scale = scaled_to_limits(
                params, joint_angles(robot, trajectory.q), tau_Nm, lower, upper
            )
            if scale < 1.0:
                self._warn(params.notes[-1])
                self._notifier.notify("Preset scaled", params.notes[-1], None, "yellow")
            else:
                self._unwarn(robot, trajectory, feedforward)
        self._state.work.set_coefficients(params, current.servo, "preset")

    def set_servos(self, params: CompensationParams, servo: ServoModel) -> None:
        """Take coefficients and virtual servos made elsewhere (a sweep point's servo settings)
        for the loaded robot; ones for other joints are refused, keeping the current ones."""
        with self._state.lock:
            robot = self._state.robot
            if robot is None or not robot.joint_names == params.joint_names == servo.joint_names:
                self._fail("Servo settings refused", "they are for another robot's joints", None)
                return
            if self._selected not in robot.joint_names or not params.enabled.any():
                self._selected = _first_enabled(params) or self._selected
            self.panel.show_joints(robot.joint_names, self._selected)
            self._state.work.set_coefficients(params, servo, "sweep")

    def set_clearance_sign(self, sign: str) -> None:
        current = self._state.work.coefficients
        if sign not in CLEARANCE_SIGNS or current is None:
            return
        params = dataclasses.replace(current.params, clearance_sign=sign)  # type: ignore[arg-type]
        self._state.work.set_coefficients(params, current.servo, "edit")

    def set_compensated_torque(self, torque: str) -> None:
        """Compensate the servos' drive torque ("drive") or the load τ ("load")."""
        current = self._state.work.coefficients
        if torque not in COMPENSATED_TORQUES or current is None:
            return
        self._state.work.set_coefficients(current.params, current.servo, "edit", torque)

    def select_joint(self, joint: str) -> None:
        self._selected = joint
        self._show_selected()

    def edit(self, edit: JointEdit) -> None:
        """One value of one joint changed: check it, update it and re-predict (τ is
        unchanged)."""
        with self._state.lock:
            current = self._state.work.coefficients
            if current is None:
                return
            try:
                params, servo = edit.apply(current.params, current.servo)
            except StudioError as error:
                self._fail("Value refused", str(error), None)
                self._show_selected()
                return
            self._state.work.set_coefficients(params, servo, "edit")

    def _show_selected(self) -> None:
        coefficients = self._state.work.coefficients
        if coefficients is None or self._selected not in coefficients.params.joint_names:
            return
        params, servo = coefficients.params, coefficients.servo
        i = params.joint_names.index(self._selected)
        self.panel.show_joint(
            bool(params.enabled[i]),
            float(params.k_deg_per_Nm[i]),
            float(params.phi_deg[i]),
            float(servo.compliance_deg_per_Nm[i]),
            float(servo.backlash_deg[i]),
        )

    # --- the quick estimate -------------------------------------------------------------------

    def predict(self) -> None:
        """The quick estimate of the current torques with the current coefficients, into the
        state (the ghosts and plots follow)."""
        with self._state.lock:
            robot, trajectory = self._state.robot, self._state.trajectory
            feedforward, coefficients = self._state.work.torques, self._state.work.coefficients
            if robot is None or trajectory is None or feedforward is None or coefficients is None:
                return
            try:
                tau_Nm = self._compensated_torque(robot, trajectory, feedforward, coefficients)
                cached = self._predictor
                if (
                    cached is None
                    or cached[0] is not feedforward
                    or (cached[1] is not tau_Nm and not np.array_equal(cached[1], tau_Nm))
                ):
                    cached = (feedforward, tau_Nm, Predictor(robot, trajectory, tau_Nm))
                    self._predictor = cached
                prediction = cached[2].predict(coefficients.params, coefficients.servo)
            except StudioError as error:
                self._fail("Cannot predict the motion", str(error), None)
                return
            absurd = implausible_prediction(prediction)
            if absurd:
                self._warn("; ".join(absurd) + " (quick estimate)")
            elif self._warned.endswith("(quick estimate)"):
                self._unwarn(robot, trajectory, feedforward)
            self._state.work.set_prediction(prediction, feedforward, coefficients)

    def _warn(self, text: str) -> None:
        self._warned = f"⚠️ {text}"
        self.panel.status.content = self._warned

    def _unwarn(self, robot: RobotModel, trajectory: Trajectory, feedforward: FeedForward) -> None:
        """The status's warning no longer holds (k back within the limits, a plausible quick
        estimate): the torques' summary again, unless something else has spoken since."""
        if self._warned and self.panel.status.content == self._warned:
            peaks = torque_peaks(robot, trajectory, feedforward)
            self.panel.status.content = torque_summary(peaks, trajectory)
        self._warned = ""

    def cached_predictor(self) -> Predictor | None:
        """The predictor of the last quick estimate (the bench times it alone)."""
        return None if self._predictor is None else self._predictor[2]

    def _compensated_torque(
        self,
        robot: RobotModel,
        trajectory: Trajectory,
        feedforward: FeedForward,
        coefficients: Coefficients,
    ) -> np.ndarray:
        """The torque eq 7 multiplies [N·m], (T, n): τ, or its drive torque with the D and J of
        the servos the simulation runs (virtual, or the parts chosen). Kept while its inputs
        are the same: a k or φ slider does not change it."""
        servo = coefficients.servo
        inputs = (robot, trajectory, feedforward, self._state.work.parts)
        cached = self._torque
        if (
            cached is not None
            and all(a is b for a, b in zip(cached[0], inputs, strict=True))
            and cached[1] == coefficients.torque
            and _same_servos(cached[2], servo)
        ):
            return cached[3]
        law = (
            simulation_law(robot, servo, self._state.work.parts)
            if coefficients.torque == "drive"
            else None
        )
        tau = np.nan_to_num(feedforward.tau_Nm)
        tau_Nm = compensated_torque_Nm(robot, trajectory, tau, coefficients.torque, servo, law)
        self._torque = (inputs, coefficients.torque, servo, tau_Nm)
        return tau_Nm

    # --- files ---------------------------------------------------------------------------------

    def export_commands(self, client: viser.ClientHandle | None = None) -> bytes | None:
        prediction, trajectory = self._state.work.prediction, self._state.trajectory
        robot = self._state.robot
        if prediction is None or trajectory is None or robot is None:
            self._fail("Nothing to export", "compute the torque feed-forward first", client)
            return None
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
            client.send_file_download(f"{file_slug(trajectory.name)}_servo_commands.csv", content)
        return content

    def _fail(self, title: str, body: str, client: viser.ClientHandle | None) -> None:
        self.panel.status.content = f"⚠️ {body}"
        self._notifier.error(title, body, client)


def default_params(robot: RobotModel) -> tuple[CompensationParams, ServoModel]:
    """The default preset on the robot (no compensation where it does not fit), and virtual
    servos on the compensated joints: the paper's servo sized to the robot (compliance and dead
    band, `app.core.servo.scaling`), so that compensation has work to do."""
    try:
        params = preset_params(DEFAULT_PRESET, robot)
    except StudioError:
        params = disabled_params(robot.joint_names)
    return params, scaled_servo_model(robot, params.enabled)


def _first_enabled(params: CompensationParams) -> str:
    return next((n for n, on in zip(params.joint_names, params.enabled, strict=True) if on), "")


def _same_servos(a: ServoModel, b: ServoModel) -> bool:
    return a is b or (
        a.joint_names == b.joint_names
        and np.array_equal(a.compliance_deg_per_Nm, b.compliance_deg_per_Nm)
        and np.array_equal(a.backlash_deg, b.backlash_deg)
    )
