"""Energy of a simulated motion on servo parts: currents, specific resistance, battery minutes.

From the parts' electrical energy (`part_law.PartEnergy`, per joint over the run):

    average supply current   Ī = Σ_j max(E_j, 0) / (vin_j · T)        [A]  (the whole pack;
                             regeneration not banked)
    average power            P̄ = Σ_j max(E_j, 0) / T                  [W]
    peak current             max_j peak |I_j| (one servo's); the pack's peak is ≤ Σ_j peak |I_j| (each joint
                             draws duty·I_j ≤ |I_j| from the supply)
    specific resistance      SR = E / (M · g · d)                        (eq 9 of the gait paper;
                             the spring paper's Table 4 measures E at the motors)
    battery                  minutes = 60 · pack_Wh / P̄                 (the motion repeated)

The electrical SR uses the distance the simulated robot's base travelled along the planned
direction (`travel_along_plan_m`: a robot that tips sideways has not walked); the planned SR the
planned work W⁺ = ∫ Σ_j max(τ_j·q̇_j, 0) dt of the feed-forward along the plan, and the planned
distance. Below MIN_DISTANCE_M (a motion in place) SR is None.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np

from app.core.errors import StudioError
from app.core.motions.trajectory import Trajectory
from app.core.robot.model import RobotModel
from app.core.simulation.part_law import PartEnergy
from app.core.simulation.result import SimulationResult

MIN_DISTANCE_M = 0.1
"""Below this horizontal travel of the base a motion is "in place" (a squat, a CoM shift):
no specific resistance."""


class BatteryError(StudioError):
    """A battery figure that cannot be used."""


def check_pack_Wh(pack_Wh: float) -> float:
    if isinstance(pack_Wh, bool) or not isinstance(pack_Wh, int | float):
        raise BatteryError(f"battery is {pack_Wh!r}; give its energy in Wh")
    if not (math.isfinite(pack_Wh) and pack_Wh > 0.0):
        raise BatteryError(f"battery is {pack_Wh} Wh; give a finite number > 0")
    return float(pack_Wh)


def specific_resistance(
    energy_J: float, mass_kg: float, distance_m: float, gravity_m_s2: float = 9.81
) -> float | None:
    """SR = E / (M·g·d); None for a motion in place (d < MIN_DISTANCE_M)."""
    if distance_m < MIN_DISTANCE_M:
        return None
    return energy_J / (mass_kg * gravity_m_s2 * distance_m)


def battery_minutes(pack_Wh: float, average_power_W: float) -> float:
    """Minutes of the motion repeated on a pack of `pack_Wh` (all of it usable)."""
    pack_Wh = check_pack_Wh(pack_Wh)
    if average_power_W <= 0.0:
        return math.inf
    return 60.0 * pack_Wh / average_power_W


def positive_work_J(tau_Nm: np.ndarray, dq_rad_s: np.ndarray, dt_s: float) -> float:
    """W⁺ = ∫ Σ_j max(τ_j·q̇_j, 0) dt by the trapezoid rule over samples (T, n) dt apart."""
    power = np.maximum(np.asarray(tau_Nm) * np.asarray(dq_rad_s), 0.0).sum(axis=1)
    if len(power) < 2:
        return 0.0
    return float(np.sum(0.5 * (power[1:] + power[:-1])) * dt_s)


def horizontal_travel_m(base_xy_m: np.ndarray) -> float:
    """|xy_end − xy_start| of the base [m], shape (T, 2)."""
    return float(np.linalg.norm(base_xy_m[-1] - base_xy_m[0]))


def travel_along_plan_m(simulated_xy_m: np.ndarray, planned_xy_m: np.ndarray) -> float:
    """The simulated base's displacement along the planned one's direction [m] when the plan
    travels MIN_DISTANCE_M or more (a robot that tips sideways has not walked that far); its
    horizontal displacement for a motion in place. Both (T, 2)."""
    planned = horizontal_travel_m(planned_xy_m)
    if planned < MIN_DISTANCE_M:
        return horizontal_travel_m(simulated_xy_m)
    direction = (planned_xy_m[-1] - planned_xy_m[0]) / planned
    return float((simulated_xy_m[-1] - simulated_xy_m[0]) @ direction)


@dataclasses.dataclass(frozen=True)
class EnergyFigures:
    duration_s: float
    electrical_J: float
    """Σ_j E_j (regeneration netted within each joint)."""
    joule_J: float
    average_power_W: float
    average_current_A: float
    """The whole pack's average supply current Ī (all servos together)."""
    peak_current_A: float
    """The largest single servo's peak |I_j| (not the pack's: an "average" of the pack can
    exceed it); `labelled_currents` says which is which."""
    peak_current_bound_A: float
    """Σ_j peak |I_j|: an upper bound on the pack's peak."""
    mass_kg: float
    distance_m: float
    planned_distance_m: float
    planned_work_J: float
    """NaN where not computed (a motion in place)."""
    sr_electrical: float | None
    sr_planned: float | None
    pack_Wh: float | None = None
    battery_minutes: float | None = None

    def to_json(self) -> dict[str, object]:
        """Strict JSON: a figure that is not finite (no travel, no draw) is null. The keys of
        the fields, and the two currents again under names that say whose they are."""
        fields = dataclasses.asdict(self) | {
            "pack_average_current_A": self.average_current_A,
            "one_servo_peak_current_A": self.peak_current_A,
        }
        return {
            k: None if isinstance(v, float) and not math.isfinite(v) else v
            for k, v in fields.items()
        }

    def labelled_currents(self) -> str:
        """The currents with whose they are, e.g. "pack average 6.70 A; peak 4.70 A on one
        servo (pack peak ≤ 21.3 A)"."""
        return (
            f"pack average {self.average_current_A:.2f} A; peak {self.peak_current_A:.2f} A on "
            f"one servo (pack peak ≤ {self.peak_current_bound_A:.2f} A)"
        )


def energy_figures(
    energy: PartEnergy,
    vin_V: np.ndarray,
    mass_kg: float,
    gravity_m_s2: float,
    simulated_xy_m: np.ndarray,
    planned_xy_m: np.ndarray,
    planned_work_J: float,
    pack_Wh: float | None = None,
) -> EnergyFigures:
    """The module docstring's figures from a run's energy and the parts' supply voltages (n,)."""
    duration = energy.duration_s
    if not duration > 0.0:
        raise BatteryError("the simulation recorded no time: no energy figures")
    drawn = np.maximum(energy.electrical_J, 0.0)
    power = float(drawn.sum()) / duration
    distance = travel_along_plan_m(simulated_xy_m, planned_xy_m)
    planned = horizontal_travel_m(planned_xy_m)
    total = float(energy.electrical_J.sum())
    return EnergyFigures(
        duration_s=duration,
        electrical_J=total,
        joule_J=float(energy.joule_J.sum()),
        average_power_W=power,
        average_current_A=float(np.sum(drawn / np.asarray(vin_V, dtype=float))) / duration,
        peak_current_A=float(energy.peak_current_A.max(initial=0.0)),
        peak_current_bound_A=float(energy.peak_current_A.sum()),
        mass_kg=mass_kg,
        distance_m=distance,
        planned_distance_m=planned,
        planned_work_J=planned_work_J,
        sr_electrical=specific_resistance(total, mass_kg, distance, gravity_m_s2),
        sr_planned=specific_resistance(planned_work_J, mass_kg, planned, gravity_m_s2),
        pack_Wh=None if pack_Wh is None else check_pack_Wh(pack_Wh),
        battery_minutes=None if pack_Wh is None else battery_minutes(pack_Wh, power),
    )


def run_energy_figures(
    result: SimulationResult,
    robot: RobotModel,
    trajectory: Trajectory,
    vin_V: np.ndarray,
    planned_torques: Callable[[], np.ndarray | None],
    pack_Wh: float | None = None,
) -> EnergyFigures:
    """`energy_figures` of a run of `trajectory` on parts: over the stretch simulated (a fall
    ends it), the planned work from `planned_torques()` [N·m] (T, n_actuated), asked for only
    when the plan travels MIN_DISTANCE_M or more (None: no planned SR)."""
    assert result.energy is not None, "a run on parts has its energy"
    planned_xy = trajectory.q[:, :2]
    work = float("nan")
    if horizontal_travel_m(planned_xy) >= MIN_DISTANCE_M:  # SR only for a motion that travels
        tau = planned_torques()
        if tau is not None:
            speed = trajectory.v[:, [joint.idx_v for joint in robot.joints]]
            work = positive_work_J(tau, speed, trajectory.dt)
    shown = result.t <= result.simulated_until_s
    return energy_figures(
        result.energy,
        vin_V,
        robot.mass_kg,
        float(np.linalg.norm(robot.model.gravity.linear)),
        result.q[shown, :2],
        planned_xy,
        work,
        pack_Wh,
    )
