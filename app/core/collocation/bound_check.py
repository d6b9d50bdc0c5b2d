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
from app.core.collocation.sampling import interval_grid, sample_states
from app.core.collocation.transcription import STANCE, GaitLayout, other, swing_z_rows


def check_bounds(model: PlanarModel, result: GaitResult) -> BoundCheck:
    """The bounds of `result.settings` on a grid of check_per_interval samples per interval:
    the three modes sampled in one go (sample_states) and their contact points in one call of
    the model's mapped function (PlanarModel.contact_positions_at)."""
    s = result.settings
    n = s.check_per_interval
    layout = GaitLayout.from_knots(result.structure[0])
    times, modes, swing = [], [], []
    for mode in range(3):
        nodes = layout.nodes(mode)
        t = np.concatenate(
            [interval_grid(result.t, nodes, n, inner=True).ravel(), result.t[list(nodes)]]
        )
        times.append(t)
        modes.append(np.full(len(t), mode))
        rows = np.flatnonzero(swing_z_rows(other(STANCE[mode])).any(axis=0))  # heel z, toe z
        swing.append(np.repeat(rows[:, None], len(t), axis=1))
    t = np.concatenate(times)
    q, v, u = sample_states(result, t, np.concatenate(modes))
    points = model.contact_positions_at(q)
    z = np.take_along_axis(points, np.concatenate(swing, axis=1), axis=0)  # (2, T) swing z
    joints, q = v[:, BASE_DOF:], q[:, BASE_DOF:]
    return BoundCheck(
        samples=len(t),
        per_interval=n,
        floor_penetration_m=max(float(-z.min()), 0.0),
        swing_height_excess_m=max(float(z.max() - s.swing_height_m), 0.0),
        joint_speed_excess_radps=max(float(np.abs(joints).max() - s.qd_max), 0.0),
        joint_range_excess_rad=max(
            float(np.max(q - model.upper)), float(np.max(model.lower - q)), 0.0
        ),
        torque_excess_Nm=max(float(np.abs(u).max() - s.tau_max_Nm), 0.0),
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
