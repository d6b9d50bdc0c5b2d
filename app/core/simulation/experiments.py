"""The spring-compensation paper's experiments (section 5) and the compensations the table of
docs/simulation.md compares them under.

Each experiment is a built-in motion with the paper's parameters; the paper's outcome on
Roban is quoted beside it. The compensations compared: none (q_cmd = q_plan), eq 7 with
k equal to the servos' true compliance, and eq 23 with φ = b/2 in both sign conventions
(the paper's sign(q + k·τ) and sign(τ), see `CompensationParams.clearance_sign`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence

import numpy as np

from app.core.robot.model import RobotModel
from app.core.servo.compensation import CompensationParams
from app.core.servo.model import ServoModel
from app.core.simulation.mjcf import SimOptions
from app.core.simulation.result import SimulationResult
from app.core.simulation.servo_law import ServoLaw

LIMIT_TOLERANCE_RAD = 1e-9
"""A command this far past a joint limit is on it (rounding), not clipped."""


def clip_to_limits(robot: RobotModel, q_cmd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A servo cannot be commanded past its limits: the commands (T, n) clipped to the joints'
    ranges, and where they were past them (T, n), beyond LIMIT_TOLERANCE_RAD (a planned joint
    resting on its limit, e.g. Roban S14's elbows at their ready angle, is off it by rounding
    only)."""
    lower = np.array([joint.lower for joint in robot.joints])
    upper = np.array([joint.upper for joint in robot.joints])
    q = np.asarray(q_cmd, dtype=float)
    past = (q < lower - LIMIT_TOLERANCE_RAD) | (q > upper + LIMIT_TOLERANCE_RAD)
    return np.clip(q, lower, upper), past


def clipped_commands(
    robot: RobotModel, t_s: np.ndarray, commands: Mapping[str, np.ndarray]
) -> tuple[dict[str, np.ndarray], str | None]:
    """Computed commands by label, clipped to the joint limits (`clip_to_limits`: k·τ pushes
    a joint planned on its limit past it), and a note saying how many were (None: none)."""
    out, note = {}, None
    for label, q in commands.items():
        out[label], past = clip_to_limits(robot, q)
        if past.any() and note is None:
            k, j = np.argwhere(past)[0]
            note = (
                f"{int(past.sum())} compensated command(s) past the joint limits clipped to "
                f"them ({label}), first {robot.joint_names[j]} at t = {t_s[k]:.2f} s by "
                f"{math.degrees(abs(q[k, j] - out[label][k, j])):.2g}°: a servo is not "
                "commanded past its limits"
            )
    return out, note


def with_note(
    results: Mapping[str, SimulationResult], note: str | None
) -> dict[str, SimulationResult]:
    """The results with `note` (e.g. `clipped_commands`'s) first among each run's notes."""
    return {
        label: run if note is None else dataclasses.replace(run, notes=(note, *run.notes))
        for label, run in results.items()
    }


@dataclasses.dataclass(frozen=True)
class PaperExperiment:
    key: str
    title: str
    motion: str
    params: Mapping[str, float]
    paper_without: str
    """What the paper's Roban did without compensation: "stays up" or "falls" (a simulated
    "leans on the lifted foot" is the simulation's counterpart of a fall: the floor catches
    the lifted foot that the real robot's fall began with)."""
    paper_with: str
    figures: str


PAPER_EXPERIMENTS: tuple[PaperExperiment, ...] = (
    PaperExperiment(
        "squats_5cm",
        "CoM 5 cm + three one-leg squats",
        "one_leg_squats",
        {"shift_m": 0.05},
        "stays up",
        "stays up",
        "Figs. 5–15",
    ),
    PaperExperiment(
        "squats_4.3cm",
        "CoM 4.3 cm + three one-leg squats",
        "one_leg_squats",
        {"shift_m": 0.043},
        "falls",
        "stays up",
        "Figs. 16–18",
    ),
    PaperExperiment(
        "fast_squats",
        "CoM 5 cm, squats at twice the speed",
        "one_leg_squats",
        {"shift_m": 0.05, "speed": 2.0},
        "stays up",
        "stays up",
        "Figs. 19–21",
    ),
    PaperExperiment(
        "deep_squats",
        "CoM 5 cm, squats 2 cm deeper",
        "one_leg_squats",
        {"shift_m": 0.05, "extra_depth_m": 0.02},
        "falls",
        "stays up",
        "Figs. 22–24",
    ),
)


def compensations(servo: ServoModel) -> dict[str, CompensationParams | None]:
    """The compared commands: none, eq 7 (k = c), eq 23 (φ = b/2) with either sign rule."""
    names = servo.joint_names
    on = (servo.compliance_deg_per_Nm > 0.0) | (servo.backlash_deg > 0.0)
    k = np.array(servo.compliance_deg_per_Nm)
    phi = 0.5 * np.array(servo.backlash_deg)
    return {
        "none": None,
        "eq 7": CompensationParams(names, k, np.zeros(len(names)), on),
        "eq 23, sign(q + kτ)": CompensationParams(names, k, phi, on, "command"),
        "eq 23, sign(τ)": CompensationParams(names, k, phi, on, "torque"),
    }


def run_paper_experiment(
    robot: RobotModel,
    experiment: PaperExperiment,
    servo: ServoModel,
    options: SimOptions | None = None,
    law: ServoLaw | None = None,
    only: Sequence[str] | None = None,
) -> list[dict[str, object]]:
    """One row per compensation (those named in `only`, else all): verdict (its text and
    kind), fall time, largest torso roll/pitch error [°], the lifted foot's load (time above
    5 % of the weight, peak), the motion's notes (e.g. a shift that leaves the CoM off the
    sole). `law` replaces the servo law made from `servo` and the URDF's limits (a servo sized
    to the robot: its torque limit)."""
    from app.core.dynamics.wbc import torque_feedforward
    from app.core.motions.library import run_motion
    from app.core.servo.compensation import compensated_command
    from app.core.servo.model import joint_angles
    from app.core.simulation.run import simulate_commands

    motion = run_motion(robot, experiment.motion, **experiment.params)
    traj = motion.trajectory
    tau = torque_feedforward(robot, traj).tau_Nm
    q_plan = joint_angles(robot, traj.q)
    commands = {
        label: q_plan if params is None else compensated_command(q_plan, tau, params)
        for label, params in compensations(servo.for_joints(robot.joint_names)).items()
        if only is None or label in only
    }
    clips = {label: clip_to_limits(robot, q) for label, q in commands.items()}
    clipped = {label: int(past.sum()) for label, (_q, past) in clips.items()}
    commands = {label: q for label, (q, _past) in clips.items()}
    results = simulate_commands(robot, traj, commands, servo, options, law=law)
    rows = []
    for label, result in results.items():
        summary, outcome = result.summary(), result.outcome
        assert outcome is not None  # a fresh run is always judged
        rows.append(
            {
                "robot": robot.name,
                "experiment": experiment.title,
                "compensation": label,
                "verdict": result.verdict(),
                "verdict_kind": outcome.kind,
                "fell": result.fell,
                "fall_time_s": result.fall_time_s,
                "max_roll_error_deg": summary["max_roll_error_deg"],
                "max_pitch_error_deg": summary["max_pitch_error_deg"],
                "rms_joint_error_deg": summary["rms_joint_error_deg"],
                "lifted_foot_load_s": outcome.lifted_foot_load_s,
                "lifted_foot_peak_load_frac": outcome.lifted_foot_peak_load_frac,
                "paper": experiment.paper_without if label == "none" else experiment.paper_with,
                "commands_clipped_to_limits": clipped[label],
                "motion_notes": list(motion.notes),
            }
        )
    return rows
