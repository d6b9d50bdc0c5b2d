"""A sizing written as the servo.toml `simulate --servo` reads (app.core.servo.parts): the
servo the sizing chose for each joint, or, where no servo holds a joint, the closest one (the
largest of its smaller margin, peak or thermal), said in a comment on that joint and in the
notes; a firmware kp for every joint where one is asked.

Sizing checks torque and heat (the envelope at full duty does not depend on kp); whether the
robot then stands is the parts' stiffness K = kt·vin·error_gain·kp/R against gravity, which kp
sets: `simulate` reports it as its stand check.
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


def check_kp(kp: float | None) -> float | None:
    """`kp` if a firmware P gain in (0, KP_MAX] (or None); SizingError otherwise."""
    if kp is not None and (isinstance(kp, bool) or not math.isfinite(kp) or not 0 < kp <= KP_MAX):
        raise SizingError(f"kp is {kp:g}; give a firmware P gain in (0, {KP_MAX:g}]")
    return kp


def sized_parts(sizing: Sizing, kp: float | None = None) -> SizedParts:
    """The servo.toml of `sizing` (module docstring); `kp` for every joint (None: each
    record's own firmware kp)."""
    check_kp(kp)
    lines = [
        "# Servo parts chosen by biped-studio size (margin "
        f"{sizing.margin:.0%}, by {sizing.by}): simulate --servo THIS --preset parts"
    ]
    if kp is not None:
        lines += [f"kp = {kp:g}"]
    closest = []
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
    return SizedParts("\n".join(lines) + "\n", tuple(closest))
