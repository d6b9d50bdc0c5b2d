"""Which constraints a failed gait solve left violated, measured at the point IPOPT returned.

IPOPT's status alone ("infeasible", "iteration limit") does not say which setting to change.
This module evaluates, at the last iterate, the violation of every constraint row and variable
bound, takes the largest per constraint group (the tags of the NLP's rows: swing height,
clearance, dynamics, contacts, …; the variable blocks: torques, speeds, joint ranges), and names
the worst groups with their values and the sliders or robot limits that set them. Groups of
different units are ranked by their violation over the robot's own scale (`Scales`: its weight
for forces, its leg for lengths, …), and reported in their units. Nothing is guessed: a group
is named only when it is violated by more than IPOPT's tolerance. When every
constraint holds, the solve stopped on optimality (the gait is feasible but not proven optimal)
and the message says so. A torque or speed bound that most entries sit on is added as context
("torques at their bound on 35 % of the entries"), as measured.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from app.core.collocation.nlp import SolveOutcome, SxNlp
from app.core.collocation.settings import GaitSettings

VIOLATED = 1e-6
"""A group is violated when its largest violation exceeds this (IPOPT's constr_viol_tol, in
the constraint's own units)."""
NAMED_GROUPS = 3
"""At most this many violated groups are named, worst first."""
SATURATED_SHARE = 0.2
"""A torque or speed bound is mentioned when this share of its entries sits on the bound."""

UNITS = {
    "swing": "m",
    "clearance": "m",
    "touchdown": "m/s",
    "lifting": "m/s",
    "range_mid": "rad",
    "speed_mid": "rad/s",
    "exchange": "rad or rad/s",
    "dynamics": "N, N·m or m/s",
    "u": "N·m",
    "v": "rad/s",
    "q": "m or rad",
    "slack": "",
    "T": "s",
}


@dataclasses.dataclass(frozen=True)
class Scales:
    """What makes one unit of violation of each group as large as another's."""

    weight_N: float
    """The robot's weight m·g [N]: the scale of the equations of motion."""
    leg_m: float
    """The robot's straight-leg standing height [m]: the scale of lengths."""
    gravity: float = 9.81

    def of(self, group: str, s: GaitSettings) -> float:
        speed = (self.gravity * self.leg_m) ** 0.5  # [m/s]
        return {
            "dynamics": self.weight_N,
            "impact": self.weight_N * 0.1,  # [N·s]: the weight over 0.1 s
            "contact": self.leg_m,
            "swing": self.leg_m,
            "clearance": self.leg_m,
            "periodicity": self.leg_m,
            "touchdown": speed,
            "lifting": speed,
            "u": s.tau_max_Nm,
            "v": s.qd_max,
            "speed_mid": s.qd_max,
            "durations": s.H_s,
            "T": s.H_s,
        }.get(group, 1.0)  # rad, unitless slack, friction in N (scaled below)


@dataclasses.dataclass(frozen=True)
class GroupViolation:
    group: str
    """A constraint tag of the NLP's rows or a variable block name."""
    violation: float
    """Largest violation of the group's rows or bounds at the point, in its units."""
    rows: int
    """How many of its rows or bounds are violated by more than VIOLATED."""
    relative: float = 0.0
    """violation over the group's scale (Scales.of): what ranks the groups."""


def words(group: str, s: GaitSettings) -> str:
    """The constraint group in a user's words: what it is and which slider sets it."""
    return {
        "u": f"the joint torque bound |τ| ≤ {s.tau_max_Nm:g} N·m (the robot's effort limit)",
        "v": f"the joint speed bound |q̇| ≤ {s.qd_max:g} rad/s (the robot's speed limit)",
        "q": "the joint ranges, the pelvis height (slider 'pelvis height ≤ × standing') or "
        "the knee bend (slider 'knee bend ≥')",
        "slack": "the foothold slack bounds (slider 'slack0 bounds [a, b]')",
        "T": "the mode durations (slider 'H, two steps')",
        "swing": f"the swing height ≤ {s.swing_height_m:g} m (slider 'swing height ≤')",
        "clearance": f"the swing clearance ≥ {min(s.swing_clearance_m, s.swing_height_m):g} m "
        "at mid-swing (slider 'swing clearance ≥')",
        "touchdown": f"the touch-down speed ≤ {s.touchdown_speed_max_mps:g} m/s "
        "(slider 'touch-down speed ≤')",
        "lifting": "the lifting heel's upward speed after a touch-down",
        "range_mid": "the joint ranges between knots",
        "speed_mid": f"the joint speed bound |q̇| ≤ {s.qd_max:g} rad/s between knots",
        "exchange": "the joint-state exchange between the legs (the legs differ)",
        "dynamics": "the equations of motion (sliders 'H, two steps', 'advance, two steps', "
        "or the robot's torque limit)",
        "contact": "the stance foot staying flat and still on the floor",
        "friction": "the friction cone (slider 'μ')",
        "impact": "the touch-down impact equations",
        "periodicity": "the periodicity of the gait (slider 'advance, two steps')",
        "durations": "the mode durations summing to H (slider 'H, two steps')",
    }.get(group, group or "the untagged constraints")


def group_violations(
    outcome: SolveOutcome,
    nlp: SxNlp,
    g_bounds: tuple[np.ndarray, np.ndarray],
    x_bounds: tuple[np.ndarray, np.ndarray] | None = None,
    scales: Scales | None = None,
    settings: GaitSettings | None = None,
) -> list[GroupViolation]:
    """Every constraint group's largest violation at `outcome`'s point, worst first relative
    to `scales` (groups that hold are included, with their violation ≤ VIOLATED)."""
    lbg, ubg = g_bounds
    g_group = np.full(len(outcome.g), "", dtype=object)
    for tag, slices in nlp.g_blocks.items():
        for sl in slices:
            g_group[sl] = tag
    parts = [(g_group, _excess(outcome.g, lbg, ubg))]
    if x_bounds is not None:
        x_group = np.full(len(outcome.x), "", dtype=object)
        for block, slices in nlp.x_blocks.items():
            for sl in slices:
                x_group[sl] = block
        parts.append((x_group, _excess(outcome.x, *x_bounds)))
    found: dict[str, GroupViolation] = {}
    for groups, excess in parts:
        for group in sorted(set(groups)):
            values = excess[groups == group]
            worst = float(values.max(initial=0.0))
            scale = 1.0
            if scales is not None and settings is not None:
                scale = scales.of(str(group), settings)
                scale = scales.weight_N if group == "friction" else scale
            here = GroupViolation(str(group), worst, int((values > VIOLATED).sum()), worst / scale)
            if group not in found or here.relative > found[group].relative:
                found[str(group)] = here
    return sorted(found.values(), key=lambda v: -v.relative)


def _excess(values: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    excess = np.maximum(lower - values, values - upper).clip(min=0.0)
    return np.where(np.isfinite(excess), excess, 0.0)


def hardest_constraint(
    outcome: SolveOutcome,
    nlp: SxNlp,
    g_bounds: tuple[np.ndarray, np.ndarray],
    settings: GaitSettings,
    x_bounds: tuple[np.ndarray, np.ndarray] | None = None,
    scales: Scales | None = None,
) -> str:
    """One sentence on what a solve that did not converge left violated at its last point:
    the worst groups (relative to `scales`) with their violations, or that everything held.
    `g_bounds` and `x_bounds` are the (lower, upper) bounds of that solve."""
    groups = group_violations(outcome, nlp, g_bounds, x_bounds, scales, settings)
    violated = [g for g in groups if g.violation > VIOLATED][:NAMED_GROUPS]
    context = _saturated(outcome.x, nlp, x_bounds, settings)
    if not violated:
        worst = max((g.violation for g in groups), default=0.0)
        return (
            f"At its last point every constraint holds (largest violation {worst:.1e} ≤ "
            f"{VIOLATED:g}): the solver stopped before it could prove that gait optimal, not on "
            f"a constraint.{context}"
        )
    named = "; ".join(
        f"{words(g.group, settings)} by {g.violation:.3g} {UNITS.get(g.group, '')}".rstrip()
        + f" ({g.rows} row{'s' if g.rows != 1 else ''})"
        for g in violated
    )
    return f"Violated at its last point, worst first: {named}.{context}"


def _saturated(
    x: np.ndarray,
    nlp: SxNlp,
    x_bounds: tuple[np.ndarray, np.ndarray] | None,
    settings: GaitSettings,
) -> str:
    """ " (torques at their bound on 35 % of the entries: the joint torque bound |τ| ≤ … N·m
    (the robot's effort limit))" (or speeds), or "": the bound named with where it is set."""
    if x_bounds is None:
        return ""
    lbx, ubx = x_bounds
    notes = []
    for group, what in (("u", "torques"), ("v", "joint speeds")):
        slices = nlp.x_blocks.get(group, [])
        if not slices:
            continue
        index = np.concatenate([np.arange(sl.start, sl.stop) for sl in slices])
        span = np.where(np.isfinite(ubx - lbx), ubx - lbx, 1.0)[index]
        near = (np.abs(x[index] - lbx[index]) < 1e-3 * span) | (
            np.abs(ubx[index] - x[index]) < 1e-3 * span
        )
        if near.mean() >= SATURATED_SHARE:
            notes.append(
                f"{what} at their bound on {100 * near.mean():.0f} % of the entries: "
                + words(group, settings)
            )
    return f" ({'; '.join(notes)})" if notes else ""
