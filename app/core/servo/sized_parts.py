"""A sizing written as the servo.toml `simulate --servo` reads (app.core.servo.parts): the
servo the sizing chose for each joint, or, where no servo holds a joint, the closest one (the
largest of its smaller margin, peak or thermal), said in a comment on that joint and in the
notes; a firmware kp for every joint where one is asked.

Each joint gets the kp the sizing chose (app.core.servo.kp_sizing: the smallest that stands
and keeps the sag bound; a closest servo whose range holds none: its largest kp), unless one
kp is given for every joint (`size --kp`): whether the robot then stands is the parts'
stiffness K = kt·vin·error_gain·kp/R against gravity, which `simulate` reports as its stand
check.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re

from app.core.servo.parts import KP_MAX
from app.core.servo.sizing import Sizing, SizingError


@dataclasses.dataclass(frozen=True)
class SizedParts:
    """The servo.toml of a sizing: its text, and the joints that got the closest servo."""

    text: str
    closest: tuple[str, ...]
    """Joints no servo holds (given the closest servo)."""
    softer: tuple[str, ...] = ()
    """Joints where a kp given for all is below the kp their stiffness needs."""


def check_kp(kp: float | None) -> float | None:
    """`kp` if a firmware P gain in (0, KP_MAX] (or None); SizingError otherwise."""
    if kp is not None and (isinstance(kp, bool) or not math.isfinite(kp) or not 0 < kp <= KP_MAX):
        raise SizingError(f"kp is {kp:g}; give a firmware P gain in (0, {KP_MAX:g}]")
    return kp


def sized_parts(sizing: Sizing, kp: float | None = None) -> SizedParts:
    """The servo.toml of `sizing` (module docstring); `kp` for every joint (None: the kp the
    sizing chose per joint where it chose one, else the record's own); a joint sized on m6
    gets friction_model = "m6", the fit its kp was chosen on."""
    check_kp(kp)
    lines = [
        "# Servo parts chosen by biped-studio size (margin "
        f"{sizing.margin:.0%}, by {sizing.by}): simulate --servo THIS --preset parts"
    ]
    if kp is not None:
        lines += [f"kp = {kp:g}"]
    closest, softer = [], []
    for joint in sizing.joints:
        if joint.choice is not None:
            key, comment = joint.choice, ""
        else:
            best = max(joint.checks, key=lambda c: min(c.peak_margin, c.thermal_margin))
            key = best.servo
            comment = f"  # no servo holds it; the closest: {'; '.join(best.violations())}"
            closest.append(joint.joint)
        name = (
            joint.joint if re.fullmatch(r"[A-Za-z0-9_-]+", joint.joint) else json.dumps(joint.joint)
        )
        lines += ["", f"[joints.{name}]", f"servo = {json.dumps(key)}{comment}"]
        chosen = joint.check(key).stiffness
        if chosen is not None and chosen.stated:  # no kp law: the stiffness it needs
            lines.append(f"stiffness_Nm_per_rad = {chosen.stated_Nm_per_rad:g}")
            continue
        if chosen is not None and chosen.fit != "m1":  # the fit its kp was chosen on
            lines.append(f"friction_model = {json.dumps(chosen.fit)}")
        if chosen is None or not chosen.checked:
            continue
        if kp is None:  # no kp in range stiff enough (a closest servo): its stiffest
            lines.append(f"kp = {chosen.kp if chosen.kp is not None else chosen.kp_max:g}")
        elif kp > chosen.kp_max:
            raise SizingError(
                f"kp is {kp:g}, outside {key}'s firmware range 0 … {chosen.kp_max:g} "
                f"({joint.joint})"
            )
        elif chosen.kp is None or kp < chosen.kp:
            softer.append(joint.joint)
    return SizedParts("\n".join(lines) + "\n", tuple(closest), tuple(softer))
