"""The spring-compensation paper's experiments (section 5) and the compensations the README's
table compares them under.

Each experiment is a built-in motion with the paper's parameters; the paper's outcome on
Roban is quoted beside it. The compensations compared: none (q_cmd = q_plan), eq 7 with
k equal to the servos' true compliance, and eq 23 with φ = b/2 in both sign conventions
(the paper's sign(q + k·τ) and sign(τ), see `CompensationParams.clearance_sign`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import numpy as np

from app.core.servo.compensation import CompensationParams
from app.core.servo.model import ServoModel


@dataclasses.dataclass(frozen=True)
class PaperExperiment:
    key: str
    title: str
    motion: str
    params: Mapping[str, float]
    paper_without: str
    """What the paper's Roban did without compensation: "stays up" or "falls"."""
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
