"""The Simulation rows' specific resistance of runs on the ideal (virtual) servo: per run of a
motion that travels, "SR x electrical (ideal servo, stated motor) · y planned work", from
`app.core.simulation.ideal_energy.run_ideal_sr` (the function `biped-studio simulate` prints
its `ideal_servo_energy` with). Runs on servo parts have their own energy line
(`servo_parts.energy_line`). Not a session: the simulation session owns one `IdealSRText`.
"""

from __future__ import annotations

import threading

import numpy as np

from app.core.dynamics.wbc import FeedForward
from app.core.servo.model import ServoModel
from app.core.simulation.battery import MIN_DISTANCE_M, horizontal_travel_m
from app.core.simulation.ideal_energy import IdealSR, run_ideal_sr
from app.core.simulation.mjcf import SimOptions
from app.core.simulation.part_law import PartLaw
from app.core.simulation.servo_law import ServoLaw, robot_servo_law
from app.studio.simulation_runner import Simulation

LABEL = "electrical (ideal servo, stated motor)"


class IdealSRText:
    """The lines of the last simulation asked for, kept (the rows are redrawn when a run is
    marked stale: the energy is not computed again)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._last: tuple[Simulation, FeedForward | None, str] | None = None

    def lines(
        self, simulation: Simulation, torques: FeedForward | None, servo: ServoModel | None
    ) -> str:
        """Markdown lines, "" for a motion in place or runs on servo parts. `torques`: the
        motion's feed-forward (the planned work); `servo`: the virtual servos, for a run
        restored from a project (its job, with the law it ran, is not kept)."""
        with self._lock:
            last = self._last
            if last is not None and last[0] is simulation and last[1] is torques:
                return last[2]
        text = ideal_sr_lines(simulation, torques, servo)
        with self._lock:
            self._last = (simulation, torques, text)
        return text


def _laws(simulation: Simulation, servo: ServoModel | None) -> dict[str, ServoLaw | None]:
    """Per run, the ideal servo law it ran on; None for a run on servo parts."""
    job = simulation.job
    if job.inputs:
        return {
            label: None if isinstance(inp.law, PartLaw) else inp.law
            for label, inp in zip(job.labels, job.inputs, strict=True)
        }
    law = None if servo is None else robot_servo_law(simulation.robot, servo)
    return {
        label: None if result.energy is not None else law
        for label, result in simulation.results.items()
    }


def ideal_sr_lines(
    simulation: Simulation, torques: FeedForward | None, servo: ServoModel | None
) -> str:
    """`IdealSRText.lines`, computed."""
    trajectory, robot = simulation.trajectory, simulation.robot
    if horizontal_travel_m(trajectory.q[:, :2]) < MIN_DISTANCE_M or not simulation.results:
        return ""
    tau = None
    if torques is not None and torques.tau_Nm.shape == (trajectory.n_samples, robot.n_actuated):
        tau = np.nan_to_num(torques.tau_Nm)
    job = simulation.job
    hold = {label: inp.linear_hold for label, inp in zip(job.labels, job.inputs, strict=True)}
    lines, motor = [], ""
    for label, law in _laws(simulation, servo).items():
        if law is None:
            continue
        sr = run_ideal_sr(
            simulation.results[label],
            robot,
            trajectory,
            law,
            lambda: tau,
            SimOptions().timestep_s,
            hold.get(label, False),
        )  # fmt: skip  (the studio simulates with the default options: simulation_runner)
        lines.append(f"{label}: {_line(sr)}")
        motor = sr.energy.motor
    if not lines:
        return ""
    return "  \n".join([*lines, f"stated motor: {motor} (no regeneration credit)"])


def _line(sr: IdealSR) -> str:
    electrical = (
        f"SR **{sr.sr_electrical:.3g}** {LABEL}"
        if sr.sr_electrical is not None
        else f"no electrical SR ({LABEL}: covered {sr.distance_m:.2f} m)"
    )
    planned = "" if sr.sr_planned is None else f" · {sr.sr_planned:.3g} planned work"
    over = (
        f" ({sr.energy.electrical_J.sum():.1f} J up to the fall at {sr.until_s:.2f} s, over "
        f"the {sr.distance_m:.2f} m it covered)"
        if sr.fell
        else f" ({sr.energy.electrical_J.sum():.1f} J over {sr.distance_m:.2f} m)"
    )
    return electrical + planned + over
