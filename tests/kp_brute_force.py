"""A brute force over (servo, kp grid) for the sizing's kp (app.core.servo.kp_sizing), written
from the records' TOML files, BAM's m1 files and the stand check, not through the code under
test: per joint the cheapest servo that holds its points and heat (the caller's `holds`) and,
where the record has firmware constants, a whole kp in 1 … kp_max whose stiffness
K = kt·vin·error_gain·kp/R is at least (1 + stand margin)·K* on a leg joint (K* = 1 / the
stand check's uniform leg compliance) and (max|τ| + friction_base) / max sag; with that
servo's smallest such kp (None for a servo without firmware constants: not checked)."""

from __future__ import annotations

import json
import math
import tomllib
from collections.abc import Callable

import numpy as np

from app.core.dynamics.stand_stiffness import stand_check
from app.core.servo.catalogue import BAM_PARAMS_DIR, SERVOS_DIR
from app.core.servo.kp_sizing import MAX_SAG_DEG, STAND_MARGIN
from app.core.servo.sizing import check_joint


def toml_records() -> dict[str, dict]:
    """The built-in records as their files say, by key."""
    return {(d := tomllib.loads(p.read_text()))["key"]: d for p in SERVOS_DIR.glob("*.toml")}


def leg_stiffness_to_stand(robot, q_stand: np.ndarray) -> tuple[float, set[int]]:
    """(K* [N·m/rad], the leg joints) of the stand check at q_stand."""
    check = stand_check(robot, q_stand, np.zeros(robot.n_actuated))
    return 1.0 / math.radians(check.max_leg_compliance_deg_per_Nm), set(check.leg_joints)


def cheapest_pairs(
    robot,
    q_stand: np.ndarray,
    tau: np.ndarray,
    costs: dict[str, float],
    holds: Callable[[int, str], bool],
    stand_margin: float = STAND_MARGIN,
    max_sag_deg: float = MAX_SAG_DEG,
) -> list[tuple[str | None, float | None]]:
    """Per joint (servo, kp) of least (cost, key) (module docstring); (None, None) where no
    servo does. `costs`: the candidates' masses (or prices) by key."""
    records = toml_records()
    k_star, legs = leg_stiffness_to_stand(robot, q_stand)
    out: list[tuple[str | None, float | None]] = []
    for j in range(robot.n_actuated):
        pairs: list[tuple[float, str, float | None]] = []
        for key, cost in costs.items():
            if not holds(j, key):
                continue
            record = records[key]
            if "firmware" not in record:
                pairs.append((cost, key, None))
                continue
            fw = record["firmware"]
            m1 = json.loads((BAM_PARAMS_DIR / record["identified"] / "m1.json").read_text())
            grid = np.arange(1, int(fw["kp_max"]) + 1, dtype=float)
            k = m1["kt"] * fw["vin_V"] * fw["error_gain"] * grid / m1["R"]
            sag = (np.abs(tau[:, j]).max() + m1["friction_base"]) / math.radians(max_sag_deg)
            ok = k >= sag
            if j in legs:
                ok &= k >= (1.0 + stand_margin) * k_star
            if ok.any():
                pairs.append((cost, key, float(grid[ok][0])))
        best = min(pairs, default=None, key=lambda p: (p[0], p[1]))
        out.append((None, None) if best is None else (best[1], best[2]))
    return out


def studio_sizing_pairs(studio, margin: float, **bounds: float):
    """`cheapest_pairs` for the motion *Size servos* last sized in `studio` (its works, the
    servos it offered, held at `margin`), by mass; `bounds`: stand_margin, max_sag_deg."""
    session = studio.servo_rooms.servos
    _, works = session.last
    (work,) = works.values()
    records = session.records
    return cheapest_pairs(
        studio.state.robot, studio.state.trajectory.q[0], work.torque_Nm,
        {key: record.mass_kg for key, record in records.items()},
        lambda j, key: check_joint(
            records[key], work.speed_rad_s[:, j], work.torque_Nm[:, j], 1.0, margin
        ).holds,
        **bounds,
    )  # fmt: skip
