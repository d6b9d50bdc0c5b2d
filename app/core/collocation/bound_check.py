"""Checks of a solved gait between its knots, on a fine grid, and its impact losses.

The NLP enforces the joint ranges, the joint speed bound and the swing foot's floor and height
bounds at the knots *and* at the collocation mid-points; between them q(t) and v(t) are cubic
Hermite splines (sampling.py) that may still overshoot a little. `check_bounds` samples every
interval at `GaitSettings.check_per_interval` points and reports the largest excess of each
bound (0 where it holds).

Impacts (eq. 4 with a plastic touch-down): M (v⁺ − v⁻) = Jᵀ Λ and J v⁺ = 0, so the kinetic
energy lost is ΔE = ½ v⁻ᵀ M v⁻ − ½ v⁺ᵀ M v⁺ = ½ (v⁻ − v⁺)ᵀ M (v⁻ − v⁺) ≥ 0 [J]. Over a periodic
gait the joints must put that energy back, so it belongs to the mechanical cost of walking.
"""

from __future__ import annotations

import numpy as np

from app.core.collocation.planar_model import BASE_DOF, PlanarModel, evaluate
from app.core.collocation.result import BoundCheck, GaitResult
from app.core.collocation.sampling import sample_gait
from app.core.collocation.transcription import STANCE, GaitLayout, other, swing_z_rows


def check_bounds(model: PlanarModel, result: GaitResult) -> BoundCheck:
    """The bounds of `result.settings` on a grid of check_per_interval samples per interval."""
    s = result.settings
    n = s.check_per_interval
    layout = GaitLayout.from_knots(result.structure[0])
    floor = height = speed = excess_range = torque = 0.0
    count = 0
    for mode in range(3):
        nodes = list(layout.nodes(mode))
        t = np.concatenate(
            [np.linspace(result.t[k], result.t[k + 1], n + 1)[1:-1] for k in nodes[:-1]]
            + [result.t[nodes]]
        )
        samples = sample_gait(result, t, np.full(len(t), mode))
        rows = swing_z_rows(other(STANCE[mode]))
        points = evaluate(model.contact_positions.map(len(t)), samples.q.T)
        z = rows @ points.reshape(8, -1)
        floor = max(floor, float(-z.min()))
        height = max(height, float(z.max() - s.swing_height_m))
        joints = samples.v[:, BASE_DOF:]
        speed = max(speed, float(np.abs(joints).max() - s.qd_max))
        q = samples.q[:, BASE_DOF:]
        excess_range = max(
            excess_range, float(np.max(q - model.upper)), float(np.max(model.lower - q))
        )
        torque = max(torque, float(np.abs(samples.u).max() - s.tau_max_Nm))
        count += len(t)
    return BoundCheck(
        samples=count,
        per_interval=n,
        floor_penetration_m=max(floor, 0.0),
        swing_height_excess_m=max(height, 0.0),
        joint_speed_excess_radps=max(speed, 0.0),
        joint_range_excess_rad=max(excess_range, 0.0),
        torque_excess_Nm=max(torque, 0.0),
    )


def impact_losses(model: PlanarModel, result: GaitResult) -> np.ndarray:
    """Kinetic energy lost at the right then the left touch-down [J], shape (2,)."""
    layout = GaitLayout.from_knots(result.structure[0])
    out = np.zeros(2)
    for j in (0, 1):
        pre, post = layout.last(j), layout.first(j + 1)
        jump = result.v[post] - result.v[pre]
        out[j] = 0.5 * jump @ evaluate(model.mass_matrix, result.q[pre]) @ jump
    return out
