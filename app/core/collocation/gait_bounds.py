"""The gait NLP's values per solve: its parameters and bounds from the settings.

Every slider that bounds something (joint ranges, |q̇| ≤ qd_max, |τ| ≤ τ_max, slack ∈ [a, b],
swing height and clearance, touch-down speed) sets lbx/ubx/lbg/ubg here, so a slider change
re-solves the same compiled problem (nlp.py).
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from app.core.collocation.nlp import CompiledNlp, SxNlp
from app.core.collocation.planar_model import BASE_DOF, PlanarModel
from app.core.collocation.settings import GaitSettings
from app.core.collocation.transcription import GaitLayout

BASE_Z_LOW_RATIO = 0.4
"""Lowest base height, as a fraction of the straight-leg standing height (keeps IPOPT sane)."""
BASE_PITCH_BOUNDS_RAD = (-0.8, 0.8)
BASE_SPEED_MAX = 10.0
"""Bound on the base's x and z speeds [m/s] (loose: keeps IPOPT's iterates sane)."""
BASE_PITCH_RATE_MAX = 20.0
"""[rad/s]"""


class BoundedGait(Protocol):
    """What the bounds are read from (a GaitProblem)."""

    model: PlanarModel
    nlp: SxNlp
    layout: GaitLayout
    baseline: bool
    compiled: CompiledNlp
    knot_swing: list[slice]


def gait_parameters(nlp: SxNlp, s: GaitSettings) -> np.ndarray:
    """The NLP's parameters p for settings `s`."""
    values = {
        "H": s.H_s, "d": s.step_length_m, "mu": s.mu, "K0": s.K0, "K1": s.K1, "K2": s.K2,
        "K_impact": s.K_impact,
    }  # fmt: skip
    p = np.zeros(len(nlp.p_index))
    for name, i in nlp.p_index.items():
        p[i] = values[name]
    return p


def gait_bounds(problem: BoundedGait, s: GaitSettings) -> tuple[np.ndarray, ...]:
    """(lbx, ubx, lbg, ubg) of `problem`'s NLP for settings `s`: the slider values that are
    bounds (joint ranges, |q̇|, |τ|, slack, swing height, clearance…)."""
    m, nlp = problem.model, problem.nlp
    lbx, ubx = np.full(nlp.nx, -np.inf), np.full(nlp.nx, np.inf)
    blocks = nlp.x_blocks
    h0 = m.standing_height_m
    z_low, z_high = BASE_Z_LOW_RATIO * h0, s.pelvis_height_ratio * h0
    lo_q = np.concatenate([[-np.inf, z_low, BASE_PITCH_BOUNDS_RAD[0]], m.lower])
    hi_q = np.concatenate([[np.inf, z_high, BASE_PITCH_BOUNDS_RAD[1]], m.upper])
    for side in ("left", "right"):
        knee = m.leg_joints[side][1]
        if m.bodies[knee - BASE_DOF + 1].axis_sign > 0:  # flexion = +q (foot moves back)
            lo_q[knee] = max(lo_q[knee], s.knee_flexion_min_rad)
        else:
            hi_q[knee] = min(hi_q[knee], -s.knee_flexion_min_rad)
    speed = [BASE_SPEED_MAX] * 2 + [BASE_PITCH_RATE_MAX] + [s.qd_max] * m.nu
    for sl in blocks["q"]:
        lbx[sl], ubx[sl] = lo_q, hi_q
    for sl in blocks["v"]:
        lbx[sl], ubx[sl] = -np.array(speed), np.array(speed)
    for sl in blocks["u"]:
        lbx[sl], ubx[sl] = -s.tau_max_Nm, s.tau_max_Nm
    for name in ("lam", "lam_mid", "impulse"):
        for sl in blocks[name]:
            lbx[sl.start + 1 : sl.stop] = 0.0  # vertical forces push
    if problem.baseline:
        (sl,) = blocks["T"]
        lbx[sl] = np.array([0.05, 0.25, 0.05]) * s.H_s
        ubx[sl] = np.array([0.5, 0.75, 0.5]) * s.H_s
        (sl,) = blocks["x1"]
        lbx[sl], ubx[sl] = -0.5, s.step_length_m + 0.5
    else:
        (sl,) = blocks["slack"]
        lbx[sl], ubx[sl] = s.slack_a, s.slack_b
    lbg, ubg = problem.compiled.lbg.copy(), problem.compiled.ubg.copy()
    for sl in nlp.g_blocks["swing"]:
        lbg[sl], ubg[sl] = 0.0, s.swing_height_m
    L = problem.layout
    for j in (0, 1):  # both soles are on the floor at a touch-down: q_post = q_pre
        for node in (L.last(j), L.first(j + 1)):
            # The landing foot before, the lifting foot after: their heights are 0 by the
            # stance rows of the node on the other side, so a bound here would only repeat
            # an equality, and an active inequality that repeats one leaves its multiplier
            # unbounded (IPOPT then stalls).
            sl = problem.knot_swing[node]
            lbg[sl], ubg[sl] = -np.inf, np.inf
    for sl in nlp.g_blocks["range_mid"]:
        lbg[sl], ubg[sl] = m.lower, m.upper
    for sl in nlp.g_blocks["speed_mid"]:
        lbg[sl], ubg[sl] = -s.qd_max, s.qd_max
    for sl in nlp.g_blocks["touchdown"]:
        lbg[sl], ubg[sl] = -s.touchdown_speed_max_mps, s.touchdown_speed_max_mps
    for sl in nlp.g_blocks.get("exchange", []):
        lbg[sl], ubg[sl] = -m.exchange_tolerance, m.exchange_tolerance
    for sl in nlp.g_blocks["clearance"]:
        lbg[sl] = min(s.swing_clearance_m, s.swing_height_m)
        ubg[sl] = s.swing_height_m
    return lbx, ubx, lbg, ubg
