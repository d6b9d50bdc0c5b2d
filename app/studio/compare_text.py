"""The two kinds of torso-error figure the studio shows, each under its own heading.

The *quick estimate* (app.core.servo.model: the servos' sag from the feed-forward torques, the
robot rigid on its planned stance foot, no dynamics) sits in the Plots panel; the *simulation*
(MuJoCo physics, app.core.simulation) sits in the Compensation panel's verdict. They answer
the same question with different models and give different numbers: every line names which
one it is, and a heading never covers both.
"""

from __future__ import annotations

import numpy as np

from app.core.servo.model import Prediction
from app.core.simulation.balance_feedback import LABEL
from app.core.simulation.verdicts import pair_text
from app.studio.simulation_runner import WITH, WITHOUT, Simulation

QUICK_ESTIMATE = "Quick estimate"
SIMULATION = "Simulation (MuJoCo)"


def quick_estimate_summary(prediction: Prediction) -> str:
    """The quick estimate's largest torso errors (Plots panel)."""
    e = prediction.attitude_errors_deg()
    return (
        f"**{QUICK_ESTIMATE}** (servo sag from the torques, no physics), largest torso error "
        f"vs plan:  \nquick estimate, no compensation: roll {e['roll_uncompensated']:.2f}°, "
        f"pitch {e['pitch_uncompensated']:.2f}°  \nquick estimate, compensated: roll "
        f"{e['roll_compensated']:.2f}°, pitch {e['pitch_compensated']:.2f}°"
    )


def simulation_summary(simulation: Simulation, drift_m: dict[str, float] | None = None) -> str:
    """The simulation's verdicts and largest torso errors (Compensation panel); `drift_m`: per
    run, how far its stance foot strayed from the plan's [m] (its ghost is drawn without it)."""
    waited = simulation.waited_s
    took = "restored from the project" if waited is None else f"in {waited:.1f} s"
    lines = [f"**Simulated** (MuJoCo) {took}:"]
    for label in (WITHOUT, WITH):
        run = simulation.results[label]
        roll = np.degrees(np.max(np.abs(run.roll_rad - run.roll_planned_rad)))
        pitch = np.degrees(np.max(np.abs(run.pitch_rad - run.pitch_planned_rad)))
        line = f"{label}: **{run.verdict()}**; "
        alone = simulation.unaided.get(label)
        if alone is not None and run.outcome is not None and alone.outcome is not None:
            line = f"{label}: **{pair_text(run.outcome, alone.outcome, f'with {LABEL}')}**; "
            line += f"{run.verdict()}; "
        line += (
            f"simulated largest torso error roll {roll:.2f}°, "
            f"pitch {pitch:.2f}° (×{run.real_time_factor:.0f} real time)"
        )
        if drift_m is not None and label in drift_m:
            line += f"; its feet strayed up to {100 * drift_m[label]:.1f} cm from the plan's"
        lines.append(line)
    if drift_m:
        lines.append(
            "The simulated ghosts are drawn on the plan's stance foot, without that drift."
        )
    notes = (note for label in (WITHOUT, WITH) for note in simulation.results[label].notes)
    lines += [f"note: {note}" for note in dict.fromkeys(notes)]
    return "  \n".join(lines)
