"""A whole-body walk of N steps from a solved periodic gait cycle: start, steps, rest.

Timeline (the cycle's modes: 0 = end of the left support, 1 = right support, 2 = start of the
next left support; H = T0 + T1 + T2, advance d per cycle):
- start, `start_s` long, double support: the feet stand where they are at the cycle's right
  touch-down (left at its foothold, right at x1); the base goes from rest (CoM between the
  feet) to the cycle's post-impact state there by a quintic in x, z and pitch (positions
  and the forward speed ẋ matched; ż, pitch rate and accelerations zero at both ends:
  matching dircon_biped's post-impact pitch rate, −1.1 rad/s, overshoots its pitch by 0.2 rad
  and the front leg cannot follow), so z and pitch rates jump there as at a touch-down; the
  legs follow by planar leg IK. The quintic (the ramp) takes the whole start when the legs
  can follow it with both soles flat, else the longest of RAMP_FRACTIONS of it they can
  follow, the base standing at rest before it (a ramp of T from rest to ẋ starts ẋ·T/2
  behind the touch-down, so a shorter ramp needs less reach). Only when no ramp fits does
  the walk stand still at the touch-down pose and jump to the gait's speed: on servos that
  jump is a fall (Roban S14's default walk: the body never gets the speed, lags its feet
  and tips backwards; with a matched ramp its walk stays up, docs/simulation.md);
- N steps of H/2 each from that touch-down: the periodic cycle, shifted by d every cycle;
- stop, `stop_s` long, double support after the last touch-down: a quintic from its
  post-impact state back to rest.
The sagittal walk is then lifted to 3-D (lift.py): feet `step_width_m` apart, base moved
sideways by the LIPM sway (sway.py) whose ZMP reference is the stance foot in single support
and moves between the feet in double support. Velocities and accelerations are finite
differences of the lifted configurations (pinocchio's difference, step 1 ms), one-sided at the
phase boundaries so that no difference crosses a touch-down.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pinocchio as pin

from app.core.collocation.guess import LegPosture
from app.core.collocation.planar_model import BASE_DOF, PlanarModel, evaluate
from app.core.collocation.result import GaitResult
from app.core.collocation.sampling import sample_gait
from app.core.errors import StudioError
from app.core.motions.trajectory import Trajectory
from app.core.walking.lift import LegLifter
from app.core.walking.sway import lateral_sway, smoothstep

MAX_STEPS = 100
STOP_BALANCE = 0.5
"""Where the walk comes to rest, between the end of a steady deceleration from the gait's
speed (0: x + ẋ·T/2, the CoM near the front foot's toe) and the CoM over the middle of the two
soles (1). Measured on servo_biped's 6-step walk with eq 7 on the drive torque and 1 s held
after it: at 0 the robot tips over forward 0.4 s after the walk; at 1 the stop reverses the
base harder than the whole-body QP can follow (10 samples infeasible: the ZMP leaves the
soles); at 0.5 every sample is feasible and the robot stands after the walk."""
RAMP_FRACTIONS = tuple(1.0 - i / 16 for i in range(13))
"""The ramps tried for the start (stop), as fractions of its duration, longest first (1 down
to 1/4 in steps of 1/16)."""
MIN_RAMP_S = 0.1
"""Shortest ramp tried [s]: a shorter one asks an acceleration no sole can push."""
REACH_TOLERANCE_M = 1e-6
"""Largest sole-point error of a double-support posture that still counts as reached [m]."""


class WalkError(StudioError):
    """A walk that cannot be built from this gait (no gait, bad step count or width)."""


@dataclasses.dataclass(frozen=True)
class Footprint:
    side: str
    x_m: float
    y_m: float
    t_on_s: float
    """When the foot lands (0 for the start stance) [s]."""
    t_off_s: float
    """When it lifts (the walk's end for the final stance) [s]."""


@dataclasses.dataclass(frozen=True)
class Walk:
    trajectory: Trajectory
    footprints: tuple[Footprint, ...]
    com_y_m: np.ndarray
    """Planned lateral CoM (LIPM) per sample [m]."""
    zmp_y_m: np.ndarray
    """Its lateral ZMP per sample [m]."""
    zmp_ref_y_m: np.ndarray
    """The ZMP reference: stance foot, or between the feet in double support [m]."""
    step_width_m: float
    foot_residual: float
    """Largest foot pose error of the leg IK (norm of log₆) [m, rad]: ~0 when each leg has
    six joints; dircon_biped (no ankle roll) cannot keep a foot flat while the base sways."""
    notes: tuple[str, ...]


@dataclasses.dataclass(frozen=True)
class _Segment:
    t0: float
    t1: float
    kind: str
    """"start", "step" or "stop"."""
    contacts: tuple[bool, bool]
    cycle: int = 0
    mode: int = 0


def _quintic(p0, v0, a0, p1, v1, a1, T: float, t: float) -> np.ndarray:
    """The quintic with the given position, velocity and acceleration at t = 0 and t = T."""
    A = np.array(
        [
            [1, 0, 0, 0, 0, 0],
            [0, 1, 0, 0, 0, 0],
            [0, 0, 2, 0, 0, 0],
            [1, T, T**2, T**3, T**4, T**5],
            [0, 1, 2 * T, 3 * T**2, 4 * T**3, 5 * T**4],
            [0, 0, 2, 6 * T, 12 * T**2, 20 * T**3],
        ]
    )
    c = np.linalg.solve(A, np.vstack([p0, v0, a0, p1, v1, a1]))
    return np.array([1, t, t**2, t**3, t**4, t**5]) @ c


class _PlanarWalk:
    """The sagittal walk: planar configuration at any time of a given segment."""

    def __init__(self, planar: PlanarModel, result: GaitResult, steps: int, start_s, stop_s):
        self.planar, self.result = planar, result
        T0, T1, _ = result.durations_s
        self.H, self.d = result.duration_s, result.settings.step_length_m
        self.T0, self.half = T0, 0.5 * self.H
        self.start_s, self.steps = start_s, steps
        self.posture = LegPosture(planar)
        self._warm_from: _Segment | None = None
        end_tau = T0 + steps * self.half
        self.tau_end = end_tau
        segments = [_Segment(0.0, start_s, "start", (True, True))]
        tau = T0
        bounds = np.array([0.0, T0, T0 + T1, self.H])
        while tau < end_tau - 1e-9:
            cycle = math.floor(tau / self.H + 1e-9)
            inside = tau - cycle * self.H
            mode = int(np.searchsorted(bounds[1:], inside + 1e-9, side="right"))
            stop = min(cycle * self.H + bounds[mode + 1], end_tau)
            side = (True, False) if mode != 1 else (False, True)
            segments.append(
                _Segment(start_s + tau - T0, start_s + stop - T0, "step", side, cycle, mode)
            )
            tau = stop
        self.walk_end = start_s + end_tau - T0
        segments.append(_Segment(self.walk_end, self.walk_end + stop_s, "stop", (True, True)))
        self.segments = segments
        self.start_state = self._cycle_state(T0, 0, 1)
        last = segments[-2]
        self.end_state = self._cycle_state(end_tau, last.cycle, last.mode + 1)
        self.match_speed = {"start": True, "stop": True}
        self.ramp_s = {"start": start_s, "stop": segments[-1].t1 - segments[-1].t0}
        self.notes: list[str] = []
        for seg in (segments[0], segments[-1]):
            length = seg.t1 - seg.t0
            ramps = [f * length for f in RAMP_FRACTIONS if f == 1.0 or f * length >= MIN_RAMP_S]
            for ramp in ramps:
                self._set_ramp(seg.kind, ramp)
                if self._reachable(seg):
                    break
            else:
                # The legs cannot follow the base from rest to the gait's speed with both feet
                # down (dircon_biped's front leg is almost straight at touch-down): stand still
                # at the touch-down pose and let the speed jump there, like a push.
                self.match_speed[seg.kind] = False
                self._set_ramp(seg.kind, length)
                self.notes.append(
                    f"the legs cannot {'reach' if seg.kind == 'start' else 'leave'} the gait's "
                    f"speed with both feet down in {length:.2f} s, within the soles: the walk "
                    f"{'starts' if seg.kind == 'start' else 'stops'} with a jump in speed "
                    "(on servos a body that never gets the speed falls; shorter steps let "
                    "the legs reach it)"
                )

    def _set_ramp(self, kind: str, ramp_s: float) -> None:
        """The start's (stop's) quintic takes `ramp_s` [s]; the rest pose it leaves from
        (comes to) is as far behind (ahead) as a steady acceleration from (to) the gait's speed
        travels in that time: x_rest = x ∓ ẋ·ramp/2, so that x(t) moves one way only."""
        self.ramp_s[kind] = ramp_s
        self._warm_from = None
        if kind == "start":
            if not self.match_speed["start"]:
                self.rest_start = self.start_state[0][:BASE_DOF].copy()
            else:
                self.rest_start = self._rest(self.start_state, -ramp_s)
        elif not self.match_speed["stop"]:
            self.rest_end = self.end_state[0][:BASE_DOF].copy()
        else:
            plain = self._rest(self.end_state, ramp_s)
            balanced = self._balanced(self.end_state[0], plain)
            self.rest_end = plain + STOP_BALANCE * (balanced - plain)

    def _speed(self, v: np.ndarray, kind: str) -> np.ndarray:
        """The base velocity the start/stop quintic meets: (ẋ, 0, 0), or 0 when standing."""
        return np.array([v[0] if self.match_speed[kind] else 0.0, 0.0, 0.0])

    def _cycle_state(self, tau: float, cycle: int, mode: int) -> tuple[np.ndarray, ...]:
        s = sample_gait(self.result, np.array([tau - cycle * self.H]), np.array([mode]))
        q = s.q[0].copy()
        q[0] += cycle * self.d
        return q, s.v[0], s.a[0]

    def feet_x(self, q: np.ndarray) -> dict[str, float]:
        p = evaluate(self.planar.contact_positions, q).reshape(4, 2)
        return {"left": float(p[:2, 0].mean()), "right": float(p[2:, 0].mean())}

    def _rest(self, state: tuple[np.ndarray, ...], duration_s: float) -> np.ndarray:
        """Base (x, z, pitch) at rest before (duration < 0) or after a touch-down state."""
        q, v = state[0], state[1]
        return np.array([q[0] + 0.5 * v[0] * duration_s, q[1], q[2]])

    def _balanced(self, stance: np.ndarray, rest: np.ndarray, rounds: int = 4) -> np.ndarray:
        """The rest base (x, z, pitch) moved along x until the whole-body CoM is over the middle
        of the two soles (the mean of their contact points); `STOP_BALANCE` says how far
        towards it the stop goes."""
        points = evaluate(self.planar.contact_positions, stance).reshape(4, 2)
        middle = float(points[:, 0].mean())
        feet = {side: (x, 0.0) for side, x in self.feet_x(stance).items()}
        base = rest.copy()
        for _ in range(rounds):  # the legs' CoM moves with the base: a few fixed-point rounds
            q = self.posture.solve(base, feet, warm=stance)
            base[0] += middle - float(evaluate(self.planar.com, q)[0])
        return base

    def _reachable(self, segment: _Segment, samples: int = 12) -> bool:
        """Whether both soles stay flat on their footholds through a double-support segment
        and the sagittal ZMP of its ramp, x − z·ẍ/g of the CoM, stays between the rearmost and
        the foremost sole point (a ramp too short asks an acceleration no sole can push)."""
        stance = self.start_state[0] if segment.kind == "start" else self.end_state[0]
        goal = evaluate(self.planar.contact_positions, stance).reshape(4, 2)
        ramp = self.ramp_s[segment.kind]
        t0 = segment.t1 - ramp if segment.kind == "start" else segment.t0
        times = np.linspace(t0, t0 + ramp, samples)
        com = np.empty((samples, 2))
        for i, t in enumerate(times):
            q = self.at(segment, float(t))
            p = evaluate(self.planar.contact_positions, q).reshape(4, 2)
            if np.abs(p - goal).max() > REACH_TOLERANCE_M:
                return False
            com[i] = np.asarray(evaluate(self.planar.com, q)).reshape(-1)[:2]
        step = times[1] - times[0]
        xdd = np.gradient(np.gradient(com[:, 0], step), step)
        zmp = com[:, 0] - (com[:, 1] - goal[:, 1].mean()) * xdd / self.planar.gravity
        return bool(np.all((zmp >= goal[:, 0].min()) & (zmp <= goal[:, 0].max())))

    def at(self, segment: _Segment, t: float) -> np.ndarray:
        if segment.kind == "step":
            tau = t - self.start_s + self.T0 - segment.cycle * self.H
            s = sample_gait(self.result, np.array([tau]), np.array([segment.mode]))
            q = s.q[0].copy()
            q[0] += segment.cycle * self.d
            return q
        if segment.kind == "start":
            end, rest, T = self.start_state, self.rest_start, self.ramp_s["start"]
            local = max(0.0, t - (segment.t1 - T))  # at rest until the ramp
            base = _quintic(
                rest,
                0 * rest,
                0 * rest,
                end[0][:3],
                self._speed(end[1], segment.kind),
                0 * rest,
                T,
                local,
            )
            stance = end[0]
        else:
            end, rest, T = self.end_state, self.rest_end, self.ramp_s["stop"]
            local = min(t - segment.t0, T)  # at rest after the ramp
            base = _quintic(
                end[0][:3],
                self._speed(end[1], segment.kind),
                0 * rest,
                rest,
                0 * rest,
                0 * rest,
                T,
                local,
            )
            stance = end[0]
        feet = self.feet_x(stance)
        if self._warm_from is not segment:  # first call on this segment: start from its end
            self._warm_from = segment
            warm: np.ndarray | None = stance
        else:
            warm = None
        return self.posture.solve(base, {side: (x, 0.0) for side, x in feet.items()}, warm=warm)


def build_walk(
    planar: PlanarModel,
    result: GaitResult,
    steps: int = 4,
    step_width_m: float | None = None,
    dt: float = 0.01,
    start_s: float | None = None,
    stop_s: float | None = None,
) -> Walk:
    """The walk of `steps` steps from the solved cycle `result` on `planar`'s robot.

    step_width_m: lateral distance between the feet [m] (None: their distance with every joint
    at zero); start_s, stop_s: durations of the start and stop double supports [s] (None: one
    gait cycle H each); dt: sample time [s]."""
    _check(planar, result, steps, dt)
    H = result.duration_s
    start_s = H if start_s is None else float(start_s)
    stop_s = H if stop_s is None else float(stop_s)
    if not (start_s >= 4 * dt and stop_s >= 4 * dt):
        raise WalkError(f"start_s and stop_s must be at least 4 samples ({4 * dt:g} s)")
    before_stop = start_s + steps * 0.5 * H
    stop_s = math.ceil((before_stop + stop_s) / dt - 1e-9) * dt - before_stop  # ends on a sample
    walk = _PlanarWalk(planar, result, steps, start_s, stop_s)
    lifter = LegLifter(planar, step_width_m if step_width_m is not None else 0.0)
    if step_width_m is None:
        lifter = LegLifter(planar, lifter.natural_width_m)
    elif not 0.0 <= step_width_m <= 2.0:
        raise WalkError(f"step_width_m = {step_width_m}: give a width in [0, 2] m")
    width = lifter.step_width_m
    total = walk.segments[-1].t1
    t = np.arange(math.floor(total / dt + 1e-9) + 1) * dt
    which = np.array(
        [
            next(
                (i for i, seg in enumerate(walk.segments) if seg.t0 - 1e-9 <= tk < seg.t1 - 1e-9),
                len(walk.segments) - 1,
            )
            for tk in t
        ]
    )
    # Lateral ZMP reference and the LIPM sway.
    p_ref = _zmp_reference(walk, t, which, width, start_s, stop_s)
    pin.centerOfMass(planar.robot.model, lifter.data, planar.to_full_q(result.q[0]))
    z_com = float(lifter.data.com[0][2])
    gravity = planar.gravity
    y, zmp = lateral_sway(p_ref, dt, math.sqrt(gravity / z_com))
    notes = []
    short = {side: len(joints) for side, joints in lifter.legs.items() if len(joints) < 6}
    if short:
        # A leg with fewer than six joints cannot hold its foot flat under a pelvis that moves
        # sideways: the walk stays sagittal (no sway, feet at their natural width).
        lifter = LegLifter(planar, lifter.natural_width_m)
        width = lifter.step_width_m
        y = np.zeros(len(t))
        zmp = np.zeros(len(t))
        notes.append(
            f"{planar.robot.name}'s legs have {min(short.values())} joints (no ankle roll): a "
            "foot cannot stay flat while the pelvis sways sideways, so this walk has no lateral "
            "sway and its CoM stays between the feet; in single support it is not over the "
            "stance sole, so the whole-body QP cannot balance those samples"
        )
    q, v, a, contacts = lifter.samples(
        lambda i, tk: walk.at(walk.segments[i], tk),
        [(seg.t0, seg.t1, seg.contacts) for seg in walk.segments],
        t,
        which,
        y,
        dt,
    )
    footprints = _footprints(walk, lifter, width, total)
    notes = walk.notes + notes
    if lifter.residual_m_rad > 1e-6:
        notes.append(
            f"the legs cannot hold the feet flat at the step width while the base sways "
            f"(foot pose error up to {lifter.residual_m_rad:.3g}): each leg needs six joints, "
            "ankle roll included, for a balanced 3-D walk"
        )
    trajectory = Trajectory(
        name=f"walk of {steps} steps",
        joint_names=planar.robot.joint_names,
        t=t,
        q=q,
        v=v,
        a=a,
        contacts=contacts,
    )
    return Walk(
        trajectory=trajectory,
        footprints=footprints,
        com_y_m=y,
        zmp_y_m=zmp,
        zmp_ref_y_m=p_ref,
        step_width_m=width,
        foot_residual=lifter.residual_m_rad,
        notes=tuple(notes),
    )


def _footprints(
    walk: _PlanarWalk, lifter: LegLifter, width: float, total: float
) -> tuple[Footprint, ...]:
    """Where each foot stands and when: the start stance, every landing, the final stance."""
    y = {"left": 0.5 * width, "right": -0.5 * width}
    start_feet = walk.feet_x(walk.start_state[0])
    prints: list[Footprint] = []
    on = {side: (start_feet[side], 0.0) for side in ("left", "right")}
    steps = walk.segments[1:-1]
    for i, seg in enumerate(steps):
        swing = "right" if seg.contacts[0] else "left"
        if swing in on:  # it lifts at the start of its swing
            x, t_on = on.pop(swing)
            prints.append(Footprint(swing, x, y[swing], t_on, seg.t0))
        if i + 1 == len(steps) or steps[i + 1].contacts != seg.contacts:  # it lands
            on[swing] = (walk.feet_x(walk.at(seg, seg.t1 - 1e-9))[swing], seg.t1)
    for side, (x, t_on) in on.items():
        prints.append(Footprint(side, x, y[side], t_on, total))
    return tuple(sorted(prints, key=lambda f: (f.t_on_s, f.side)))


def _check(planar: PlanarModel, result: GaitResult, steps: int, dt: float) -> None:
    """WalkError unless `result` is a solved gait of `planar`'s joints and steps, dt fit."""
    if not result.has_gait or not result.converged:
        raise WalkError(f"no solved gait to walk: {result.status}")
    if result.joint_names != planar.joint_names:
        raise WalkError(
            f"the gait was planned for joints {', '.join(result.joint_names)}; "
            f"{planar.robot.name} has planar joints {', '.join(planar.joint_names)}"
        )
    if not isinstance(steps, int) or not 1 <= steps <= MAX_STEPS:
        raise WalkError(f"steps = {steps!r}: give a whole number of steps in [1, {MAX_STEPS}]")
    if not dt > 0.0 or not math.isfinite(dt):
        raise WalkError(f"dt must be > 0, got {dt}")


def _zmp_reference(
    walk: _PlanarWalk, t: np.ndarray, which: np.ndarray, width: float, start_s: float,
    stop_s: float,
) -> np.ndarray:  # fmt: skip
    """The lateral ZMP reference [m] at times `t`: under the stance foot, moved smoothly onto
    the first stance foot at the start and back between the feet at the stop."""
    foot_y = {"left": 0.5 * width, "right": -0.5 * width}
    p_ref = np.zeros(len(t))
    first, last = walk.segments[1], walk.segments[-2]
    first_y = foot_y["right" if first.contacts[1] else "left"]
    last_y = foot_y["right" if last.contacts[1] else "left"]
    for k, tk in enumerate(t):
        seg = walk.segments[which[k]]
        if seg.kind == "start":
            p_ref[k] = first_y * smoothstep(np.array(tk / start_s))
        elif seg.kind == "stop":
            p_ref[k] = last_y * (1.0 - smoothstep(np.array((tk - seg.t0) / stop_s)))
        else:
            p_ref[k] = foot_y["left" if seg.contacts[0] else "right"]
    return p_ref
