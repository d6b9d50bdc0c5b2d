"""Which constraint a failed gait solve ran into, in words a user can act on.

When IPOPT stops without a gait, its status alone ("infeasible", "iteration limit") does not
say which setting to change. At the point it returned, a constraint group either is violated
(the largest violation names it), or, if everything holds to the tolerance, pushes hardest on
the solution (the largest sum of |multipliers| names it). Each group maps to the slider or
robot limit that sets it.
"""

from __future__ import annotations

import numpy as np

from app.core.collocation.nlp import SolveOutcome, SxNlp
from app.core.collocation.settings import GaitSettings

VIOLATED_M = 1e-4
"""A group violated by more than this (m, rad, N·m, … in the constraint's units) is blamed
before any multiplier is looked at."""


def _words(group: str, s: GaitSettings) -> str:
    return {
        "u": f"the joint torque bound |τ| ≤ {s.tau_max_Nm:g} N·m (the robot's effort limit)",
        "v": f"the joint speed bound |q̇| ≤ {s.qd_max:g} rad/s (the robot's speed limit)",
        "q": "the joint ranges, the pelvis height (slider 'pelvis height ≤ × standing') or "
        "the knee bend (slider 'knee bend ≥')",
        "slack": "the foothold slack bounds (slider 'slack0 bounds [a, b]')",
        "T": "the mode durations (slider 'H, two steps')",
        "swing": "the swing height (slider 'swing height ≤')",
        "clearance": "the swing clearance (slider 'swing clearance ≥')",
        "touchdown": "the touch-down speed (slider 'touch-down speed ≤')",
        "range_mid": "the joint ranges between knots",
        "speed_mid": f"the joint speed bound |q̇| ≤ {s.qd_max:g} rad/s between knots",
        "exchange": "the joint-state exchange between the legs (the legs differ)",
        "": "the dynamics, contacts, friction and periodicity (sliders 'H, two steps', "
        "'advance, two steps', 'μ')",
    }.get(group, group)


def hardest_constraint(
    outcome: SolveOutcome,
    nlp: SxNlp,
    g_bounds: tuple[np.ndarray, np.ndarray],
    settings: GaitSettings,
    x_bounds: tuple[np.ndarray, np.ndarray] | None = None,
) -> str:
    """What a solve that did not converge ran into: "the constraint …: WORDS". `g_bounds`
    are the constraints' (lower, upper) bounds of that solve (the variables stay inside
    theirs: IPOPT is an interior-point method)."""
    lbg, ubg = g_bounds
    g_group = np.full(len(outcome.g), "", dtype=object)
    for tag, slices in nlp.g_blocks.items():
        for sl in slices:
            g_group[sl] = tag
    x_group = np.full(len(outcome.x), "", dtype=object)
    for block, slices in nlp.x_blocks.items():
        for sl in slices:
            x_group[sl] = block
    violation = np.maximum(lbg - outcome.g, outcome.g - ubg).clip(min=0.0)
    violation = np.where(np.isfinite(violation), violation, 0.0)
    if violation.size and violation.max() > VIOLATED_M:
        group = str(g_group[int(np.argmax(violation))])
        saturated = _saturated(outcome.x, x_group, x_bounds) if group == "" else None
        if saturated is not None:  # the dynamics cannot be met because a bound is hit
            return f"the bound held most of the time: {_words(saturated, settings)}"
        return f"the constraint left most violated: {_words(group, settings)}"
    push: dict[str, float] = {}
    for groups, lam in ((g_group, outcome.lam_g), (x_group, outcome.lam_x)):
        finite = np.where(np.isfinite(lam), np.abs(lam), 0.0)
        for group in set(groups):
            push[str(group)] = push.get(str(group), 0.0) + float(finite[groups == group].sum())
    bounded = {
        k: v for k, v in push.items() if k in ("u", "v", "q", "slack", "T") or k in nlp.g_blocks
    }
    if not bounded or max(bounded.values()) == 0.0:
        return f"the constraints pushing hardest: {_words('', settings)}"
    group = max(bounded, key=lambda k: bounded[k])
    return f"the constraint pushing hardest: {_words(group, settings)}"


SATURATED_SHARE = 0.2
"""A torque or speed bound is blamed for unmet dynamics when this share of its entries sits on
the bound at the returned point."""


def _saturated(
    x: np.ndarray, x_group: np.ndarray, x_bounds: tuple[np.ndarray, np.ndarray] | None
) -> str | None:
    """ "u" or "v" when that many of its entries sit on their bounds, else None."""
    if x_bounds is None:
        return None
    lbx, ubx = x_bounds
    for group in ("u", "v"):
        mask = x_group == group
        if not mask.any():
            continue
        span = np.where(np.isfinite(ubx - lbx), ubx - lbx, 1.0)[mask]
        near = (np.abs(x[mask] - lbx[mask]) < 1e-3 * span) | (
            np.abs(ubx[mask] - x[mask]) < 1e-3 * span
        )
        if near.mean() >= SATURATED_SHARE:
            return group
    return None
