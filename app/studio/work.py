"""The current motion's work, part of the studio state (`StudioState.work`): its torque
feed-forward, the compensation coefficients and virtual servos, the servo parts per joint, the
quick estimate, and the last good simulation, each with its signal.

Every value is replaced, never changed in place, under the state's lock, and announced while
the lock is held, as the state's own setters do. A value made for a motion or robot that is no
longer the current one is dropped (the setter returns False); a new motion drops the old one's
torques, estimate and simulation silently (on_motion says so), a new robot its coefficients too.
"""

from __future__ import annotations

import dataclasses
import threading
from collections.abc import Callable
from typing import TYPE_CHECKING

from app.core.dynamics.wbc import FeedForward
from app.core.errors import StudioError
from app.core.motions.trajectory import Trajectory
from app.core.robot.model import RobotModel
from app.core.servo.choice import ServoChoice
from app.core.servo.compensation import CompensationParams
from app.core.servo.model import Prediction, ServoModel
from app.core.simulation.drive import DEFAULT_COMPENSATED_TORQUE, CompensatedTorque
from app.studio.signals import Signal

if TYPE_CHECKING:
    from app.studio.simulation_runner import SimulationRecord


@dataclasses.dataclass(frozen=True)
class Coefficients:
    """The compensation coefficients (eq 7, eq 23) and the virtual servos they are tried on, who
    set them: "robot" (the defaults of a loaded robot), "preset", "edit", "sweep" or
    "project", and the torque eq 7 multiplies (app.core.simulation.drive)."""

    params: CompensationParams
    servo: ServoModel
    origin: str
    torque: CompensatedTorque = DEFAULT_COMPENSATED_TORQUE


class MotionWork:
    """See the module docstring."""

    def __init__(
        self,
        lock: threading.RLock,
        current: Callable[[], tuple[RobotModel | None, Trajectory | None]],
    ) -> None:
        """lock: the state's; current(): the loaded robot and the current motion."""
        self._lock, self._current = lock, current
        self.torques: FeedForward | None = None
        self.coefficients: Coefficients | None = None
        self.prediction: Prediction | None = None
        """The quick estimate of the current motion with its torques and coefficients."""
        self.simulation: SimulationRecord | None = None
        """The last good simulation of the current motion, and whether it is stale."""
        self.on_torques: Signal[FeedForward] = Signal("on_torques")
        self.on_coefficients: Signal[Coefficients] = Signal("on_coefficients")
        self.on_prediction: Signal[Prediction] = Signal("on_prediction")
        self.on_simulation: Signal[SimulationRecord] = Signal("on_simulation")
        """A simulation ended, was restored, or went stale."""
        self.parts: ServoChoice | None = None
        """The servo of each joint (ideal or a catalogue part; app.core.servo.choice), the
        robot's like the coefficients; None until the Servos panel has one."""
        self.on_parts: Signal[ServoChoice] = Signal("on_parts")

    def drop(self, coefficients: bool = False) -> None:
        """Forget the motion's work (and the robot's coefficients), silently."""
        with self._lock:
            self.torques, self.prediction, self.simulation = None, None, None
            if coefficients:
                self.coefficients, self.parts = None, None

    def set_torques(self, feedforward: FeedForward, trajectory: Trajectory) -> bool:
        """The torques of `trajectory`, if it is still the current motion (False: dropped)."""
        with self._lock:
            if trajectory is not self._current()[1]:
                return False
            self.torques = feedforward
            self.on_torques.emit(feedforward)
            return True

    def set_coefficients(
        self,
        params: CompensationParams,
        servo: ServoModel,
        origin: str,
        torque: CompensatedTorque | None = None,
    ) -> None:
        """New coefficients and virtual servos, and the torque they multiply (None: the current
        choice); raises StudioError for another robot's joints."""
        with self._lock:
            robot = self._current()[0]
            if robot is None or not robot.joint_names == params.joint_names == servo.joint_names:
                raise StudioError("they are for another robot's joints")
            if torque is None:
                current = self.coefficients
                torque = current.torque if current is not None else DEFAULT_COMPENSATED_TORQUE
            self.coefficients = Coefficients(params, servo, origin, torque)
            self.on_coefficients.emit(self.coefficients)

    def set_parts(
        self,
        choice: ServoChoice,
        params: CompensationParams,
        servo: ServoModel,
        origin: str,
        torque: CompensatedTorque | None = None,
    ) -> None:
        """A new servo per joint with the coefficients and virtual servos that follow from it
        (k = 1/K, the part's dead band), installed together; raises StudioError for another
        robot's joints. on_coefficients, then on_parts."""
        with self._lock:
            robot = self._current()[0]
            if robot is None or choice.joint_names != robot.joint_names:
                raise StudioError("the servo parts are for another robot's joints")
            self.set_coefficients(params, servo, origin, torque)
            self.parts = choice
            self.on_parts.emit(choice)

    def set_sizing_bounds(self, choice: ServoChoice) -> None:
        """The current choice with other *Size servos* bounds (stand margin, largest sag):
        nothing follows from them until the next sizing, so on_parts only (the coefficients,
        estimate and simulation stand); raises StudioError for a choice that differs otherwise
        (set_parts then; before any choice is kept, one with a part or a battery)."""
        with self._lock:
            robot = self._current()[0]
            if robot is None or choice.joint_names != robot.joint_names:
                raise StudioError("the servo parts are for another robot's joints")
            now = self.parts
            if now is None:
                same = not choice.chosen and choice.battery_Wh is None  # every joint ideal
            else:
                same = (
                    dataclasses.replace(
                        choice, stand_margin=now.stand_margin, max_sag_deg=now.max_sag_deg
                    )
                    == now
                )
            if not same:
                raise StudioError("only the sizing bounds may change this way")
            self.parts = choice
            self.on_parts.emit(choice)

    def set_prediction(
        self, prediction: Prediction, torques: FeedForward, coefficients: Coefficients
    ) -> bool:
        """The quick estimate made from `torques` and `coefficients`, if they are still the
        current ones (False: dropped, a newer estimate follows)."""
        with self._lock:
            if torques is not self.torques or coefficients is not self.coefficients:
                return False
            self.prediction = prediction
            self.on_prediction.emit(prediction)
            return True

    def set_simulation(self, record: SimulationRecord) -> bool:
        """A simulation of the current motion (False: of another motion, dropped)."""
        with self._lock:
            if record.run.trajectory is not self._current()[1]:
                return False
            self.simulation = record
            self.on_simulation.emit(record)
            return True

    def mark_simulation_stale(self) -> None:
        """The coefficients or servos changed since the simulation ran."""
        with self._lock:
            if self.simulation is not None and not self.simulation.stale:
                self.simulation = dataclasses.replace(self.simulation, stale=True)
                self.on_simulation.emit(self.simulation)
