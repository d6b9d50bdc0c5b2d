"""The Pareto axes of a sweep over servo parts: what the leg servos weigh and cost, the
electrical energy they drew over the simulated walk, and the margin they keep on it.

For a point with a part (app.core.sweeps.part_parameters) on the L leg joints:

    servo_mass_kg        = Σ_legs mass_kg of the part's record            (= L · mass_kg)
    servo_cost           = Σ_legs price of the part's record              (NaN: no published price)
    electrical_energy_J  = Σ_legs ∫ V·I dt over the simulated walk (part_law.PartEnergy; a
                           walk that fell is simulated up to its fall only: its energy is
                           the energy until then, and the plot draws it as fallen)
    servo_margin         = min over the leg joints of min(peak margin, thermal margin) of the
                           part's envelope against the walk's planned torque–speed points
                           (app.core.servo.sizing.check_joint: the margins *Size servos* gives;
                           < 0 where the part cannot hold the plan)

A point without a part has NaN for all four, so a sweep that trades one of them off needs a
servo part (swept or in [part]); `servo_cost` needs every servo it may choose to publish a
price, in one currency (`check_part_metrics` says which do not).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from app.core.sweeps.robot_variants import SweepSpecError

PART_METRICS = {
    "servo_mass_kg": "total mass of the leg servos [kg] (their catalogue masses)",
    "servo_cost": "total price of the leg servos (every servo chosen from must publish one)",
    "electrical_energy_J": "electrical energy the leg servos drew over the simulated walk [J]",
    "servo_margin": "smallest peak or RMS margin of the leg servos on the walk's planned "
    "torque–speed points (0.3: 30 % headroom; < 0: the part cannot hold the plan)",
}
"""Metrics of a sweep with servo parts, with what they mean."""
MAXIMISED = ("servo_margin",)
"""The metrics that are better large: a Pareto front wants them "max" (the Sweep folder sets
that sense for them)."""


def check_part_metrics(
    metrics: Sequence[str], servos: Sequence[str], offered: dict[str, Any], source: str
) -> None:
    """A part metric needs servo parts (`servos`: the keys the sweep may put on the legs);
    servo_cost needs each of them priced in one currency. SweepSpecError naming what is
    missing."""
    wanted = [m for m in metrics if m in PART_METRICS]
    if not wanted:
        return
    if not servos:
        raise SweepSpecError(
            f"{source}: pareto metric {wanted[0]} is of servo parts: sweep servo (kind = "
            '"part") or give [part] servo = "<key>"'
        )
    if "servo_cost" not in wanted:
        return
    unpriced = sorted(k for k in servos if offered[k].price is None)
    if unpriced:
        raise SweepSpecError(
            f"{source}: pareto metric servo_cost: no published price for {', '.join(unpriced)}; "
            "choose priced servos or another metric (servo_mass_kg)"
        )
    currencies = sorted({str(offered[k].price_currency) for k in servos})
    if len(currencies) > 1:
        raise SweepSpecError(
            f"{source}: pareto metric servo_cost: prices in {', '.join(currencies)}; the "
            "servos chosen from must be priced in one currency"
        )


def part_metrics(
    robot: Any, part: Any, walk: Any, feedforward: Any, energy: Any
) -> dict[str, float]:
    """The four metrics of a point on `part` (PartSetup) whose walk (`walk.trajectory`) had
    the torques `feedforward` and was simulated with `energy` (PartEnergy, None: not known)."""
    from app.core.errors import StudioError
    from app.core.servo.sizing import check_joint
    from app.core.servo.sizing_work import motion_work
    from app.core.sweeps.part_parameters import leg_parts

    record = part.record()
    legs = leg_parts(robot, part).joint_names
    n = len(legs)
    price = record.price
    columns = [robot.joint_names.index(name) for name in legs]
    trajectory = walk.trajectory
    try:
        work = motion_work(
            robot,
            trajectory,
            np.nan_to_num(feedforward.tau_Nm),
            [int(k) for k in feedforward.infeasible_samples],
        )
        margin = min(
            _worst(check_joint(record, work.speed_rad_s[:, j], work.torque_Nm[:, j], 1.0, 0.0))
            for j in columns
        )
    except StudioError:  # every sample flagged: no planned point to hold
        margin = math.nan
    return {
        "servo_mass_kg": math.fsum([record.mass_kg] * n),
        "servo_cost": math.nan if price is None else math.fsum([price] * n),
        "electrical_energy_J": (
            math.nan if energy is None else float(np.sum(energy.electrical_J[columns]))
        ),
        "servo_margin": margin,
    }


def _worst(check: Any) -> float:
    return float(min(check.peak_margin, check.thermal_margin))


def cost_note(servos: Sequence[str], offered: dict[str, Any]) -> str:
    """Why a sweep's servo_cost is empty for some points ("" when every servo is priced)."""
    unpriced = sorted({k for k in servos if offered[k].price is None})
    if not unpriced:
        return ""
    return (
        f"servo_cost: no published price for {', '.join(unpriced)}: their points have no cost "
        "(give a price in a servo file of your own to trade cost off)"
    )
