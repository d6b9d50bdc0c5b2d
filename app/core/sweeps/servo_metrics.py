"""Servo parameters of a sweep and the simulation metrics of a point.

A sweep with `simulate = true` runs, after each point's gait solve, the pipeline the studio runs
on the gait panel's "walk it": a walk of `walk_steps` steps from standing to standing
(`build_walk`), the whole-body torque feed-forward (`torque_feedforward`), the servo commands
(eq 7, `servo_commands`) and a MuJoCo simulation of those commands on the point's servos
(`simulate`). It reports the fall verdict, the torso's largest attitude error and the joints'
largest tracking error. On dircon_biped with 2 steps that is about 1 s more per point (walk
0.4 s, torques 0.1 s, simulation 0.1–0.4 s), against 0.2–1 s for a warm gait solve.

The servos are the studio's virtual servos (`default_params` of the Compensation panel): the
same servo on every leg joint, rigid elsewhere. The servo parameters:

- `compliance_deg_per_Nm`: the servos' true compliance k [°/(N·m)] (output lag per torque);
- `dead_band_deg`: the full width of their dead band [°];
- `compensation`: 1 = compensated (eq 7 with k equal to the servos' true compliance: a
  calibrated servo; no clearance term), 0 = the plan sent as it is. Swept as a number in
  [0, 1] and rounded (≥ 0.5 is on).
"""

from __future__ import annotations

import dataclasses
import math
import time
from typing import Any

import numpy as np

from app.core.papers import TYPICAL_COMPLIANCE_DEG_PER_NM
from app.core.simulation.files import DEFAULT_BACKLASH_DEG
from app.core.sweeps.part_parameters import PartSetup, leg_parts

DEFAULT_WALK_STEPS = 2
MAX_WALK_STEPS = 8
"""Most steps a sweep's walk may have: each costs about 0.3 s of simulation per point."""


@dataclasses.dataclass(frozen=True)
class ServoParameter:
    name: str
    minimum: float
    maximum: float
    default: float
    hint: str
    is_switch: bool = False
    """Rounded to 0 or 1 (off / on)."""


SERVO_PARAMETERS: dict[str, ServoParameter] = {
    p.name: p
    for p in (
        ServoParameter(
            "compliance_deg_per_Nm",
            0.0,
            20.0,
            TYPICAL_COMPLIANCE_DEG_PER_NM,
            "the leg servos' true compliance k [°/(N·m)] (default: Table 2's identifiable servos)",
        ),
        ServoParameter(
            "dead_band_deg", 0.0, 10.0, DEFAULT_BACKLASH_DEG, "full width of the dead band [°]"
        ),
        ServoParameter(
            "compensation",
            0.0,
            1.0,
            1.0,
            "1: commands q + k·τ with k = the servos' compliance; 0: the plan as it is",
            is_switch=True,
        ),
    )
}
"""Every servo parameter a sweep can vary (or fix in its [servo] table), with its range."""


@dataclasses.dataclass(frozen=True)
class SimulationSetup:
    """What a point's simulation runs: picklable numbers, to travel to a Dask worker."""

    walk_steps: int = DEFAULT_WALK_STEPS
    compliance_deg_per_Nm: float = TYPICAL_COMPLIANCE_DEG_PER_NM
    dead_band_deg: float = DEFAULT_BACKLASH_DEG
    compensation: bool = True
    part: PartSetup | None = None
    """A catalogue servo on the leg joints (app.core.sweeps.part_parameters); None: the
    virtual servos above."""

    @classmethod
    def of(
        cls,
        walk_steps: int,
        values: dict[str, float],
        part: dict[str, Any] | None = None,
        user_records: tuple[Any, ...] = (),
    ) -> SimulationSetup:
        """The setup with the servo parameters `values` (names of SERVO_PARAMETERS) and the
        part's `part` ("servo": key, "kp": value; none: no part); `user_records`: the user's
        ServoRecords the sweep offers (the part carries its own to the worker)."""
        fields: dict[str, Any] = {"walk_steps": int(walk_steps)}
        for name, value in values.items():
            p = SERVO_PARAMETERS[name]
            fields[name] = value >= 0.5 if p.is_switch else float(value)
        if part and "servo" in part:
            kp = part.get("kp")
            fields["part"] = PartSetup(
                str(part["servo"]),
                None if kp is None else float(kp),
                float(values["dead_band_deg"]) if "dead_band_deg" in values else None,
                tuple(r for r in user_records if r.key == part["servo"]),
            )
        return cls(**fields)


@dataclasses.dataclass(frozen=True)
class SimulationMetrics:
    """What a point's simulation says (NaN where it could not run)."""

    fell: float
    """1.0 if the robot fell, 0.0 if it stayed up (a number, for tables and Pareto fronts)."""
    fall_time_s: float
    """When it fell (NaN when it stayed up) [s]."""
    max_torso_error_deg: float
    """Largest |roll| or |pitch| error of the torso against the plan [°]."""
    max_tracking_error_deg: float
    """Largest |joint angle − plan| of any joint [°]."""
    rms_joint_error_deg: float
    sim_status: str
    """The verdict ("stays up", "falls at 1.69 s (...)"), or why there is no simulation."""
    sim_s: float
    """Time of the walk, torques and simulation [s]."""
    sim_notes: str = ""
    """The run's notes, "; "-joined (e.g. commands clipped to the joint limits)."""
    servo_mass_kg: float = math.nan
    """The servo parts' metrics (app.core.sweeps.part_metrics; NaN without a part)."""
    servo_cost: float = math.nan
    electrical_energy_J: float = math.nan
    servo_margin: float = math.nan


def not_simulated(reason: str, seconds: float = 0.0) -> SimulationMetrics:
    nan = math.nan
    return SimulationMetrics(nan, nan, nan, nan, nan, reason, seconds)


SIMULATION_S_BASE, SIMULATION_S_PER_STEP = 0.2, 0.4
"""What a point's simulation costs on top of its gait solve, roughly [s]: a fixed part (torques
set-up, MuJoCo model) and a part per walk step (walk, QP, simulation); about 1 s with 2 steps on
dircon_biped here (docs/sweeps.md)."""


def simulation_cost_s(walk_steps: int) -> float:
    """The rough extra seconds per point of `simulate = true` with `walk_steps` steps."""
    return SIMULATION_S_BASE + SIMULATION_S_PER_STEP * walk_steps


def servo_settings(robot: Any, setup: SimulationSetup) -> tuple[Any, Any]:
    """(CompensationParams, ServoModel) of a setup on `robot`: the leg joints (those the
    uniform preset compensates) get the setup's compliance and dead band (with a part: its
    1/K and dead band), the others are rigid; compensation on is eq 7 with k = that compliance
    (a calibrated servo), off sends the plan."""
    from app.core.servo.choice import with_parts
    from app.core.servo.compensation import disabled_params
    from app.core.servo.model import ServoModel
    from app.core.servo.presets import uniform_preset

    legs = uniform_preset(robot).enabled
    params = uniform_preset(robot, setup.compliance_deg_per_Nm)
    servo = ServoModel(
        robot.joint_names,
        np.where(legs, setup.compliance_deg_per_Nm, 0.0),
        np.where(legs, setup.dead_band_deg, 0.0),
    )
    if setup.part is not None:
        params, servo = with_parts(params, servo, leg_parts(robot, setup.part))
    if not setup.compensation:
        params = disabled_params(robot.joint_names)
    return params, servo


def walk_and_simulate(planar: Any, gait: Any, setup: SimulationSetup) -> tuple[Any, ...]:
    """The pipeline on a solved gait: (walk, feed-forward, commands, servos, simulation result).
    Raises StudioError where a stage refuses (a walk it cannot make, a simulation that
    diverges); commands past a joint limit are clipped to it, with a note in the result's notes
    (`clipped_commands`); `commands` are the computed ones, before clipping."""
    from app.core.dynamics.wbc import torque_feedforward
    from app.core.servo.commands import servo_commands
    from app.core.simulation.drive import compensated_torque_Nm
    from app.core.simulation.experiments import clipped_commands, with_note
    from app.core.simulation.run import simulate
    from app.core.walking.walk import build_walk

    robot = planar.robot
    walk = build_walk(planar, gait, steps=setup.walk_steps)
    feedforward = torque_feedforward(robot, walk.trajectory)
    params, servo = servo_settings(robot, setup)
    law = None
    if setup.part is not None:
        from app.core.simulation.part_law import law_with_parts

        law = law_with_parts(robot, servo, leg_parts(robot, setup.part))
    # eq 7 on the servos' drive torque, as the studio compensates by default
    tau = compensated_torque_Nm(robot, walk.trajectory, feedforward.tau_Nm, "drive", servo, law)
    commands = servo_commands(robot, walk.trajectory, tau, params)
    # computed commands: clipped to the limits as a servo clips its goal (as simulate does)
    clipped, note = clipped_commands(robot, walk.trajectory.t, {"simulated": commands.q_cmd_rad})
    if law is None:
        result = simulate(robot, walk.trajectory, clipped["simulated"], servo)
    else:
        from app.core.simulation.run import simulate_commands

        result = simulate_commands(robot, walk.trajectory, clipped, servo, parallel=False, law=law)[
            "simulated"
        ]
    result = with_note({"simulated": result}, note)["simulated"]
    return walk, feedforward, commands, servo, result


def simulation_metrics(planar: Any, gait: Any, setup: SimulationSetup) -> SimulationMetrics:
    """The simulation metrics of a solved gait; a stage that refuses gives NaN and its reason."""
    from app.core.errors import StudioError
    from app.core.servo.model import joint_angles

    start = time.perf_counter()
    try:
        walk, feedforward, _commands, _servo, result = walk_and_simulate(planar, gait, setup)
    except StudioError as error:
        return not_simulated(f"not simulated: {error}", time.perf_counter() - start)
    out = metrics_of_simulation(
        result,
        joint_angles(planar.robot, walk.trajectory.q),
        time.perf_counter() - start,
    )
    if setup.part is None:
        return out
    from app.core.sweeps.part_metrics import part_metrics

    m = part_metrics(planar.robot, setup.part, walk, feedforward, result.energy)
    return dataclasses.replace(
        out,
        servo_mass_kg=m["servo_mass_kg"],
        servo_cost=m["servo_cost"],
        electrical_energy_J=m["electrical_energy_J"],
        servo_margin=m["servo_margin"],
    )


def metrics_of_simulation(result: Any, q_plan: np.ndarray, seconds: float) -> SimulationMetrics:
    """The metrics of a SimulationResult, up to where it was simulated."""
    shown = result.t <= result.simulated_until_s
    summary = result.summary()
    tracking = np.abs(result.q_joints_rad[shown] - q_plan[shown])
    return SimulationMetrics(
        fell=1.0 if result.fell else 0.0,
        fall_time_s=math.nan if result.fall_time_s is None else float(result.fall_time_s),
        max_torso_error_deg=max(
            float(summary["max_roll_error_deg"]), float(summary["max_pitch_error_deg"])
        ),
        max_tracking_error_deg=math.degrees(float(tracking.max())),
        rms_joint_error_deg=float(result.rms_joint_error_deg),
        sim_status=result.verdict(),
        sim_s=seconds,
        sim_notes="; ".join(result.notes),
    )
