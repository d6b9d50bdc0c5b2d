"""Built-in motions, parametrised like the papers' experiments, as keyframes for `interpolate`.

Spring-compensation paper (Wang et al. 2023, Sec. 5.1–5.4): shift the CoM sideways over the
stance foot (5 cm, also 4.3 cm), lift the other leg ("one-leg maintenance" = those two
stages), squat three times on one leg, the same at twice the speed and 2 cm deeper, swing the
free leg sideways or forwards after the shift. Hybrid-leg paper (Che et al. 2022, Sec. 4.1,
4.2.1): stepping with a semi-elliptical foot path and a trapezoidal ("T-shaped") speed
profile, forward distance 0, mean foot speed 41.7 mm/s (Exp. A).

The papers give no timings, squat depth, lift height or swing amplitude: ours are the
constants below, lengths as fractions of the robot's leg length (hip height) so that every
motion fits every robot. Every motion starts from the ready pose (app.core.posing.ready_pose). An
amplitude that cannot work on a robot (a 5 cm shift short of the stance sole of a
wide-hipped robot) is adapted, with a note; a motion the robot physically cannot do (no ankle
roll: the CoM cannot go over one flat foot) is returned as the IK's closest motion, with its
per-sample warnings.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping

import numpy as np

from app.core.motions.keyframes import interpolate
from app.core.motions.params import Param, parse_params
from app.core.motions.poses import KeyframeSequence, MotionError, Plan, Side
from app.core.motions.result import MotionResult
from app.core.robot.model import RobotModel

SHIFT_S, LIFT_S, HOLD_S, SQUAT_HALF_S, SWING_HALF_S, STEP_SHIFT_S = 2.0, 1.5, 2.0, 1.0, 1.0, 1.0
"""Segment durations [s] at speed 1 (ours: the paper's plots give no time values)."""
LIFT, SQUAT_DEPTH, SIDE_SWING, FRONT_SWING, STEP_HEIGHT = 0.1, 0.1, 0.08, 0.2, 0.1
"""Default amplitudes as fractions of the leg length. The free foot stays flat and the CoM
over the stance foot, so a side swing is limited by the ankle roll ranges (servo_biped
reaches about 0.09 leg lengths; Roban S14, whose ankle roll stops at ±15°, less).
STEP_HEIGHT gives 0.10 m on the ~1 m legs of dircon_biped, the gait paper's swing-height
bound."""
SOLE_MARGIN_M = 0.015
"""The CoM goes at least this far inside the stance sole (the IK's support-polygon margin is
1 cm)."""


@dataclasses.dataclass(frozen=True)
class MotionSpec:
    name: str
    description: str
    params: tuple[Param, ...]
    build: Callable[..., Plan]
    """build(robot, **params) -> Plan (keyframes and notes)."""


def _other(side: Side) -> Side:
    return "right" if side == "left" else "left"


def _shift(seq: KeyframeSequence, side: Side, shift_m: float, one_foot: bool) -> np.ndarray:
    """Append the sideways CoM shift towards the `side` foot; returns the CoM target (xy).

    The paper's shift: the CoM moves shift_m sideways from where it stands at the start. When
    the `side` foot is to carry the robot alone (`one_foot`) and that does not put the CoM over
    its sole (SOLE_MARGIN_M inside), the robot cannot stand on it: noted, and the motion is
    still made as asked, the IK letting the CoM out of the support (Plan.com_in_support), since
    the fall is the experiment."""
    ctx = seq.ctx
    com = ctx.com(seq.q)[:2]
    centre = ctx.sole_centre(seq.q, side)
    target = com + np.array([0.0, math.copysign(shift_m, centre[1] - com[1])])
    short_m = float(np.linalg.norm(ctx.over_sole(seq.q, side, target, SOLE_MARGIN_M) - target))
    if one_foot and short_m > 1e-6:
        needed_m = abs(float(ctx.over_sole(seq.q, side, com, SOLE_MARGIN_M)[1] - com[1]))
        seq.com_in_support = False
        seq.notes.append(
            f"a {shift_m * 100:.1f} cm CoM shift leaves the CoM {short_m * 100:.1f} cm short of "
            f"the {side} sole of {seq.robot.name} (over it with a {SOLE_MARGIN_M * 100:.1f} cm "
            f"margin from a {needed_m * 100:.1f} cm shift): it cannot stand on that foot; the "
            "motion is made as asked and is expected to fall"
        )
    seq.add("shift", SHIFT_S, "both", target)
    return target


def _stand_on_one_leg(
    seq: KeyframeSequence, side: Side, shift_m: float, lift_m: float | None
) -> tuple[np.ndarray, dict[Side, np.ndarray]]:
    """Shift, then lift the other foot; returns (CoM target, {free side: lifted placement})."""
    com = _shift(seq, side, shift_m, one_foot=True)
    lift = LIFT * seq.ctx.leg_length_m if lift_m is None else lift_m
    free: dict[Side, np.ndarray] = {_other(side): seq.foot(_other(side), dz=lift)}
    seq.add("lift", LIFT_S, side, com, feet=free)
    return com, free


def com_shift(robot: RobotModel, side: Side = "left", shift_m=0.05, speed=1.0) -> Plan:
    seq = KeyframeSequence(robot, speed)
    _shift(seq, side, shift_m, one_foot=False)
    return seq.plan()


def one_leg_stand(
    robot: RobotModel, side: Side = "left", shift_m=0.05, lift_m=None, speed=1.0
) -> Plan:
    seq = KeyframeSequence(robot, speed)
    com, free = _stand_on_one_leg(seq, side, shift_m, lift_m)
    seq.add("hold", HOLD_S, side, com, feet=free)
    return seq.plan()


def one_leg_squats(
    robot: RobotModel,
    side: Side = "left",
    shift_m=0.05,
    lift_m=None,
    squats=3,
    depth_m=None,
    extra_depth_m=0.0,
    speed=1.0,
) -> Plan:
    """The free foot stays where it was lifted (in the world) while the pelvis goes down."""
    seq = KeyframeSequence(robot, speed)
    com, free = _stand_on_one_leg(seq, side, shift_m, lift_m)
    top = seq.ctx.placements(seq.q)[robot.tree.root][2, 3]
    depth = (SQUAT_DEPTH * seq.ctx.leg_length_m if depth_m is None else depth_m) + extra_depth_m
    for i in range(1, squats + 1):
        seq.add(f"squat {i} down", SQUAT_HALF_S, side, com, pelvis_z=top - depth, feet=free)
        seq.add(f"squat {i} up", SQUAT_HALF_S, side, com, pelvis_z=top, feet=free)
    return seq.plan()


def _swing(robot, side: Side, shift_m, lift_m, amplitude_m, swings, speed, forwards) -> Plan:
    seq = KeyframeSequence(robot, speed)
    com, free = _stand_on_one_leg(seq, side, shift_m, lift_m)
    other = _other(side)
    default = FRONT_SWING if forwards else SIDE_SWING
    amplitude = default * seq.ctx.leg_length_m if amplitude_m is None else amplitude_m
    outwards = math.copysign(amplitude, free[other][1, 3] - seq.foot(side)[1, 3])
    moves = (
        (("forwards", amplitude, 0.0), ("backwards", -amplitude, 0.0), ("back", 0.0, 0.0))
        if forwards
        else (("out", 0.0, outwards), ("in", 0.0, 0.0))
    )
    for i in range(1, swings + 1):
        for name, dx, dy in moves:
            T = free[other].copy()
            T[:2, 3] += (dx, dy)
            seq.add(f"swing {i} {name}", SWING_HALF_S, side, com, feet={other: T})
    return seq.plan()


def side_swing(
    robot, side="left", shift_m=0.05, lift_m=None, amplitude_m=None, swings=2, speed=1.0
):
    """Swing the free foot outwards and back `swings` times."""
    return _swing(robot, side, shift_m, lift_m, amplitude_m, swings, speed, forwards=False)


def front_swing(
    robot, side="left", shift_m=0.05, lift_m=None, amplitude_m=None, swings=2, speed=1.0
):
    """Swing the free foot forwards, backwards and back under the hip, `swings` times."""
    return _swing(robot, side, shift_m, lift_m, amplitude_m, swings, speed, forwards=True)


def semi_ellipse_length_m(stride_m: float, height_m: float) -> float:
    """Length [m] of the foot path p(φ) = (½ stride (1 − cos φ), height sin φ), φ ∈ [0, π]."""
    phase = np.linspace(0.0, np.pi, 2001)
    points = np.stack([0.5 * stride_m * (1.0 - np.cos(phase)), height_m * np.sin(phase)])
    return float(np.sum(np.linalg.norm(np.diff(points, axis=1), axis=0)))


def step_in_place(
    robot: RobotModel,
    side: Side = "right",
    steps=4,
    height_m=None,
    stride_m=0.0,
    foot_speed_mps=0.0417,
) -> Plan:
    """Per step: the CoM just over the stance sole (SOLE_MARGIN_M inside it, both feet
    down), then the other foot travels its semi-ellipse (apex height_m, chord stride_m
    forwards) with a trapezoidal speed profile in its phase, lasting path length /
    foot_speed_mps. Quasi-static: the paper's robot let its CoM leave the support polygon;
    the IK here keeps it inside."""
    seq = KeyframeSequence(robot)
    height = STEP_HEIGHT * seq.ctx.leg_length_m if height_m is None else height_m
    duration = max(semi_ellipse_length_m(stride_m, height) / foot_speed_mps, 0.1)
    moving = side
    for i in range(1, steps + 1):
        stance = _other(moving)
        com = seq.ctx.over_sole(seq.q, stance, seq.ctx.com(seq.q)[:2], SOLE_MARGIN_M)
        seq.add(f"shift {i}", STEP_SHIFT_S, "both", com)
        feet: dict[Side, np.ndarray] = {moving: seq.foot(moving, dx=stride_m)}
        seq.add(
            f"step {i}",
            duration,
            stance,
            com,
            feet=feet,
            swing_height_m=height,
            profile="trapezoid",
        )
        moving = stance
    middle = 0.5 * (seq.ctx.sole_centre(seq.q, "left") + seq.ctx.sole_centre(seq.q, "right"))
    seq.add("centre", STEP_SHIFT_S, "both", middle[:2])
    return seq.plan()


_SIDE = Param(
    "side", "left", "", "stance foot (paper: CoM left, right leg lifted)", str, ("left", "right")
)
_SHIFT = Param(
    "shift_m", 0.05, "m", "sideways CoM shift towards the stance foot (paper: 0.05, 0.043)"
)
_SPEED = Param(
    "speed",
    1.0,
    "",
    "time scale: 2 runs the motion in half the time (paper: 1, 2)",
    minimum=0.01,
    maximum=100.0,
)
_LIFT = Param("lift_m", None, "m", f"foot lift; default {LIFT:g} × leg length")
_SIDE_AMPLITUDE = Param(
    "amplitude_m", None, "m", f"outward swing; default {SIDE_SWING:g} × leg length"
)
_FRONT_AMPLITUDE = Param(
    "amplitude_m", None, "m", f"forward and backward swing; default {FRONT_SWING:g} × leg length"
)
_SWINGS = Param("swings", 2, "", "number of swings", int, minimum=1)
MOTIONS: dict[str, MotionSpec] = {
    spec.name: spec
    for spec in (
        MotionSpec(
            "com_shift",
            "shift the CoM sideways towards the stance foot",
            (_SIDE, _SHIFT, _SPEED),
            com_shift,
        ),
        MotionSpec(
            "one_leg_stand",
            "CoM shift, lift the other foot, hold",
            (_SIDE, _SHIFT, _LIFT, _SPEED),
            one_leg_stand,
        ),
        MotionSpec(
            "one_leg_squats",
            "CoM shift, lift the other foot, squat on one leg",
            (
                _SIDE,
                _SHIFT,
                _LIFT,
                Param("squats", 3, "", "number of squats (paper: 3)", int, minimum=1),
                Param(
                    "depth_m",
                    None,
                    "m",
                    f"pelvis drop per squat; default {SQUAT_DEPTH:g} × leg length",
                ),
                Param("extra_depth_m", 0.0, "m", "added squat depth (paper: 0 or 0.02)"),
                _SPEED,
            ),
            one_leg_squats,
        ),
        MotionSpec(
            "side_swing",
            "CoM shift, lift, swing the free leg outwards and back",
            (_SIDE, _SHIFT, _LIFT, _SIDE_AMPLITUDE, _SWINGS, _SPEED),
            side_swing,
        ),
        MotionSpec(
            "front_swing",
            "CoM shift, lift, swing the free leg forwards and backwards",
            (_SIDE, _SHIFT, _LIFT, _FRONT_AMPLITUDE, _SWINGS, _SPEED),
            front_swing,
        ),
        MotionSpec(
            "step_in_place",
            "alternate steps: semi-elliptical foot path, trapezoidal speed (hybrid-leg paper)",
            (
                Param("side", "right", "", "foot that steps first", str, ("left", "right")),
                Param("steps", 4, "", "number of steps", int, minimum=1),
                Param(
                    "height_m",
                    None,
                    "m",
                    f"apex of the foot path; default {STEP_HEIGHT:g} × leg length",
                ),
                Param("stride_m", 0.0, "m", "forward distance per step (paper: 0)", minimum=None),
                Param(
                    "foot_speed_mps",
                    0.0417,
                    "m/s",
                    "mean foot speed along its path (paper, Exp. A: 41.7 mm/s)",
                    minimum=1e-4,
                ),
            ),
            step_in_place,
        ),
    )
}


def resolve_params(name: str, given: Mapping[str, object]) -> dict[str, object]:
    """A motion's parameters: defaults, overridden by `given` (numbers or text), checked."""
    if name not in MOTIONS:
        raise MotionError(f"no motion named {name!r}; motions are: {', '.join(MOTIONS)}")
    return parse_params(name, MOTIONS[name].params, given)


def run_motion(robot: RobotModel, name: str, dt: float = 0.01, **params) -> MotionResult:
    """Build a built-in motion for a robot and interpolate it (per-sample warnings, notes)."""
    plan = MOTIONS[name].build(robot, **resolve_params(name, params))
    result = interpolate(
        robot,
        plan.keyframes,
        dt=dt,
        name=name,
        com_in_support=plan.com_in_support,
        held_joints=plan.held_joints,
    )
    return dataclasses.replace(result, notes=plan.notes)
