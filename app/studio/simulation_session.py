"""Simulation in the studio: the plan and the compensated commands run on MuJoCo in a worker
process (app.studio.simulation_runner), with progress and cancel; the last good run goes to the
state (`StudioState.set_simulation`) with its verdicts (for a walk, how far it went and how far
each footstep landed from the plan's), and is marked stale when the coefficients or servos
change after it. Before any motion, the panel says whether the robot can stand on its virtual
servos (app.studio.stand_checker, off the UI thread), again whenever the servos change.

The one-click pipeline's last stage: a motion that asks for "simulate" is simulated as soon as
its quick estimate exists.
"""

from __future__ import annotations

import logging

import viser

from app.core.dynamics.wbc import FeedForward
from app.core.errors import StudioError
from app.core.servo.model import Prediction
from app.core.simulation.balance_feedback import LABEL as BALANCE_LABEL
from app.core.simulation.balance_feedback import BalanceGains
from app.studio.compare_text import simulation_summary
from app.studio.ideal_sr_text import IdealSRText
from app.studio.notifier import Notifier
from app.studio.servo_parts import energy_line, simulation_law
from app.studio.signals import Signal
from app.studio.simulation_runner import (
    WITH,
    Simulation,
    SimulationRecord,
    SimulationRunner,
    simulation_record,
)
from app.studio.stand_checker import StandChecker
from app.studio.state import Motion, StudioState
from app.studio.work import Coefficients
from panels.compensation_folder import CompensationFolder
from panels.simulation_panel import NO_VERDICT, SimulationPanel

log = logging.getLogger(__name__)

STALE = "⚠️ Stale: the coefficients or servos changed since this simulation; simulate again.  \n"


class SimulationSession:
    """Owns the Simulation sub-folder of the Compensation folder and the simulation worker."""

    def __init__(self, state: StudioState, notifier: Notifier, folder: CompensationFolder) -> None:
        self._state, self._notifier = state, notifier
        self.panel = SimulationPanel(folder, self, BalanceGains().text())
        self.balance: BalanceGains | None = None
        """The balance feedback's gains for the next runs (the panel's box), None: off."""
        self.runner = SimulationRunner(self._on_progress)
        self.runner.finished.connect(self._on_simulated)
        self.refused: Signal[str] = Signal("simulation_refused")
        """Emitted with the reason when a simulation cannot start (the one click stops there)."""
        self.stand = StandChecker(self._show_stand)
        """The stand check of the robot on the current virtual servos."""
        self._then: Motion | None = None
        """The motion that asked to be simulated (the one-click pipeline), not yet simulated."""
        self._ideal_sr = IdealSRText()
        """The runs' SR on the ideal servo, kept for the last simulation."""
        state.on_motion.connect(self._on_motion)
        state.work.on_torques.connect(self._on_torques)
        state.work.on_prediction.connect(self._on_prediction)
        state.work.on_coefficients.connect(self._on_coefficients)
        state.work.on_simulation.connect(self._on_simulation)

    # --- state changes ---------------------------------------------------------------------------

    def _on_motion(self, motion: Motion | None) -> None:
        self.panel.verdict.content = NO_VERDICT
        self._then = motion if motion is not None and "simulate" in motion.then else None

    def _on_torques(self, _torques: FeedForward) -> None:
        if self._then is None:
            self.runner.warm_up()  # a Simulate click next should not wait for a process to spawn

    def _on_prediction(self, _prediction: Prediction) -> None:
        if self._then is not None and self._then is self._state.motion:
            self._then = None
            self.simulate()

    def _on_coefficients(self, coefficients: Coefficients) -> None:
        if coefficients.origin != "project":
            self._state.work.mark_simulation_stale()
        robot = self._state.robot
        if robot is not None and robot.joint_names == coefficients.servo.joint_names:
            self.stand.request(robot, coefficients.servo)

    def _show_stand(self, text: str) -> None:
        self.panel.stand.content = text

    def _on_simulation(self, record: SimulationRecord) -> None:
        text = simulation_summary(record.run, record.drift_m())
        travel = travel_lines(record.run)
        if travel:
            text += "  \n" + travel
        text += _energy(record, self._state, self._ideal_sr)
        self.panel.verdict.content = STALE + text if record.stale else text

    # --- running (SimulationActions) -------------------------------------------------------------

    def simulate(self, client: viser.ClientHandle | None = None) -> None:
        """Simulate the plan and the compensated commands on MuJoCo in the worker process;
        the end is announced by `runner.finished`."""
        with self._state.lock:
            state = self._state
            robot, trajectory, prediction = state.robot, state.trajectory, state.work.prediction
            coefficients = state.work.coefficients
        if robot is None or trajectory is None or prediction is None or coefficients is None:
            self._fail("Nothing to simulate", "compute the torque feed-forward first", client)
            return
        if self.runner.running is not None:
            return
        servo = coefficients.servo
        try:
            law = simulation_law(robot, servo, self._state.work.parts)  # the servo parts' hook
            balance = self.balance
            self.runner.start(
                robot, trajectory, prediction.q_plan_rad, prediction.q_cmd_rad, servo, law, balance
            )
        except (OSError, RuntimeError) as error:  # the worker process could not start
            self._fail("Cannot simulate", f"the simulation worker did not start: {error}", client)
            return
        except StudioError as error:
            self.panel.verdict.content = f"⚠️ {error}"
            self._notifier.error("Cannot simulate", str(error), client)
            self.refused.emit(str(error))
            return
        self.panel.show_simulating(0.0)
        self.panel.verdict.content = (
            f"Simulating **{trajectory.name}** without and with compensation "
            f"({trajectory.duration:.1f} s each"
            + ("" if balance is None else f", with {BALANCE_LABEL}, then again without it")
            + ")…"
        )

    def cancel_simulation(self) -> None:
        self.runner.cancel()

    def set_balance_feedback(self, on: bool) -> None:
        """The next runs with the balance feedback at its default gains (on) or without."""
        self.balance = BalanceGains() if on else None

    def _on_progress(self, fraction: float) -> None:
        if self.runner.running is not None:
            self.panel.show_simulating(fraction)

    def _on_simulated(self, simulation: Simulation) -> None:
        self.panel.show_simulating(None)
        kept = (
            " The last good simulation is kept." if self._state.work.simulation is not None else ""
        )
        if simulation.error == "cancelled":
            self.panel.verdict.content = "Simulation cancelled." + kept
            return
        if simulation.error:
            self.panel.verdict.content = f"⚠️ Simulation failed: {simulation.error}.{kept}"
            self._notifier.error("Simulation failed", simulation.error)
            return
        record = simulation_record(simulation)  # outside the lock: a second for long motions
        self._ideal_sr.lines(simulation, self._state.work.torques, None)  # outside it too
        self._state.work.set_simulation(record)  # dropped if the motion changed meanwhile

    def close(self) -> None:
        self.runner.close()
        self.stand.close()

    def _fail(self, title: str, body: str, client: viser.ClientHandle | None) -> None:
        self.panel.status.content = f"⚠️ {body}"
        self._notifier.error(title, body, client)
        self.refused.emit(body)


def _energy(record: SimulationRecord, state: StudioState, ideal: IdealSRText) -> str:
    """The compensated run's energy line when it ran on servo parts (app.studio.servo_parts),
    and the SR of the runs on the ideal servo of a motion that travels (app.studio.ideal_sr_text)."""
    run, work = record.run, state.work
    line = energy_line(run.results[WITH], run.robot, run.trajectory, work.parts, work.torques)
    servo = None if work.coefficients is None or record.stale else work.coefficients.servo
    lines = [text for text in (line, ideal.lines(run, work.torques, servo)) if text]
    return "".join(f"  \n{text}" for text in lines)


def travel_lines(simulation: Simulation) -> str:
    """For a motion that travels, per run: "walked X of Y m (Z %)", its footsteps' placement
    errors and swing-foot scuffs (app.core.simulation.verdicts.Travel); "" otherwise."""
    lines = []
    for label, result in simulation.results.items():
        verdict = result.outcome
        if verdict is None or verdict.travel is None:
            continue
        travel = verdict.travel
        line = (
            f"{label}: walked **{travel.distance_covered_m:.2f} of {travel.distance_planned_m:.2f}"
            f" m ({100 * travel.fraction:.0f} %)**"
        )
        errors = [100 * step.error_m for step in travel.footsteps]
        if errors:
            line += (
                f"; {len(errors)} footstep{'s' if len(errors) > 1 else ''} landed "
                f"{min(errors):.1f}–{max(errors):.1f} cm from the plan's (mean "
                f"{sum(errors) / len(errors):.1f} cm)"
            )
        count = len(verdict.scuffs)
        line += f"; {count} swing-foot scuff{'' if count == 1 else 's'}"
        lines.append(line)
    return "  \n".join(lines)
