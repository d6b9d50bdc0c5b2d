"""Sizing servos against the work: each joint's torque–speed points against a servo's envelope.

The envelope is the DC motor's at its supply voltage (`motor_law`): with voltage saturation the
torque the motor gives at output speed ω lies in

    −τ_s − D·ω  ≤  τ  ≤  τ_s − D·ω,      D = τ_s / ω_0 = kt²/R      (the motor line)
    |τ| ≤ τ_lim = kt · current_limit                                  (where the firmware sets one)

— the line from stall torque τ_s (ω = 0) to no-load speed ω_0 (τ = 0) in the motoring
quadrants, and more torque when braking (τ·ω < 0). τ_s and ω_0 come from the identified motor
model and firmware (τ_s = kt·vin·max_pwm/R, ω_0 = vin·max_pwm/kt: the law the simulation
uses) where the record has one; for a servo rated by a continuous point (`rated_point`) the
line through its no-load speed and continuous point, capped at τ_c/I_c × its firmware's current
limit; else from the datasheet's stall torque and no-load speed at its rated supply voltage.

The envelope is convex and holds the origin, so a point x = (ω, τ) has a *scale*: the largest s
with s·x inside, s = min over the bounds a·x ≤ b that x pushes against (a·x > 0) of b / (a·x).
The point's margin is s − 1 (speed and torque scaled together); a joint *holds* with margin m
when every point has s ≥ 1 + m.

Thermal: the RMS torque over the motion against the continuous rating —
`continuous_torque_Nm` where the record publishes it, else the assumption
CONTINUOUS_FRACTION_OF_STALL × the torque held at rest (stall, or the current limit where lower;
said in the result's notes) — and holds when
(1 + m)·τ_rms ≤ rating.

`size_joints` picks, per joint, the lightest (or cheapest) servo that holds both; None where no
servo does.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Literal

import numpy as np

from app.core.errors import StudioError
from app.core.servo import motor_law
from app.core.servo.catalogue import ServoRecord
from app.core.servo.kp_choice import KpChoice

CONTINUOUS_FRACTION_OF_STALL = 0.25
"""The continuous rating assumed where a record publishes none: a quarter of the stall torque
(hobby servo makers rate continuous duty well below stall — ROBOTIS advises using a fraction of
the stall torque — and publish no figure; an assumption, said wherever it is used)."""

Criterion = Literal["mass", "price"]


class SizingError(StudioError):
    """Sizing inputs that cannot be used (margin, points, catalogue)."""


@dataclasses.dataclass(frozen=True)
class Envelope:
    """A servo's torque–speed envelope at its voltage (module docstring)."""

    stall_torque_Nm: float
    """Where the motor line meets ω = 0: kt·vin·max_pwm/R, not capped by the current limit (so
    the line's slope is the back-EMF's kt²/R, as in the simulation's motor law)."""
    no_load_speed_rad_s: float
    torque_limit_Nm: float
    """kt·current_limit, np.inf where none is set (or the record gives no motor model)."""
    source: str
    """"model m1 at <vin> V" or "datasheet at <V> V"."""

    @property
    def held_torque_Nm(self) -> float:
        """The most torque at rest: the stall torque, or the current limit where lower."""
        return min(self.stall_torque_Nm, self.torque_limit_Nm)

    @property
    def back_emf_Nms_per_rad(self) -> float:
        return self.stall_torque_Nm / self.no_load_speed_rad_s

    def max_torque_Nm(self, speed_rad_s: np.ndarray) -> np.ndarray:
        """The largest torque in the direction of motion at |ω| (motoring), ≥ 0 (0 past ω_0)."""
        line = self.stall_torque_Nm * (1.0 - np.abs(speed_rad_s) / self.no_load_speed_rad_s)
        return np.clip(line, 0.0, self.torque_limit_Nm)

    def scale(self, speed_rad_s: np.ndarray, torque_Nm: np.ndarray) -> np.ndarray:
        """The largest s with s·(ω, τ) inside the envelope, per point (np.inf at the origin)."""
        w = np.asarray(speed_rad_s, dtype=float)
        tau = np.asarray(torque_Nm, dtype=float)
        push = np.abs(tau + self.back_emf_Nms_per_rad * w)  # the motor line, either side
        with np.errstate(divide="ignore"):
            s = np.where(push > 0.0, self.stall_torque_Nm / push, np.inf)
            if math.isfinite(self.torque_limit_Nm):
                a = np.abs(tau)
                s = np.minimum(s, np.where(a > 0.0, self.torque_limit_Nm / a, np.inf))
        return s


def envelope(record: ServoRecord) -> Envelope:
    """The record's envelope: its m1 motor model with its firmware where identified, its
    continuous point's line and current limit where rated so, else the datasheet's stall
    torque and no-load speed."""
    rated = record.rated
    if rated is not None:
        return Envelope(
            rated.line_stall_torque_Nm,
            rated.no_load_speed_rad_s,
            rated.torque_limit_Nm,
            f"continuous-point DC model at {rated.supply_voltage_V:g} V, capped at "
            f"{rated.torque_limit_Nm:.3g} N·m (τc/Ic × current limit)",
        )
    law = record.law("m1")
    if law is not None:
        motor, firmware = law
        limit = firmware.current_limit_A
        return Envelope(
            motor.kt_Nm_per_A * firmware.vin_V * firmware.max_pwm / motor.R_ohm,
            motor_law.no_load_speed_rad_s(motor, firmware),
            math.inf if limit is None else motor.kt_Nm_per_A * limit,
            f"{'datasheet DC model' if (fit := record.fit('m1')) and fit.derived else 'model m1'}"
            f" at {firmware.vin_V:g} V",
        )
    return Envelope(
        float(record.stall_torque_Nm or 0.0),  # only a rated record has none (above)
        record.no_load_speed_rad_s,
        math.inf,
        f"datasheet at {record.supply_voltage_V:g} V",
    )


def continuous_torque_Nm(
    record: ServoRecord, fraction: float = CONTINUOUS_FRACTION_OF_STALL
) -> tuple[float, bool]:
    """(rating [N·m], assumed?): the published continuous torque, else `fraction` of the
    torque the envelope holds at rest (its stall torque, or the current limit where lower)."""
    published = record.continuous_torque_Nm
    if published is not None:
        return float(published), False
    return fraction * envelope(record).held_torque_Nm, True


def check_fraction(fraction: float) -> float:
    if isinstance(fraction, bool) or not isinstance(fraction, int | float):
        raise SizingError(f"continuous fraction is {fraction!r}; give a number in (0, 1]")
    if not (math.isfinite(fraction) and 0.0 < fraction <= 1.0):
        raise SizingError(f"continuous fraction is {fraction}; give a number in (0, 1] of stall")
    return float(fraction)


@dataclasses.dataclass(frozen=True)
class Check:
    """One servo on one joint's points."""

    servo: str
    peak_margin: float
    """min over points of (scale − 1); np.inf for a joint that never loads."""
    worst_sample: int
    """The sample of the smallest scale (−1 without points)."""
    rms_torque_Nm: float
    continuous_torque_Nm: float
    continuous_assumed: bool
    margin: float
    work: str = ""
    """The motion the worst point is in (several motions: `combine`)."""
    rms_work: str = ""
    """The motion of the largest RMS torque."""
    stiffness: KpChoice | None = None
    worst_torque_Nm: float = 0.0
    """The torque of the worst point (its speed: worst_speed_rad_s)."""
    worst_speed_rad_s: float = 0.0
    """The firmware kp the stiffness needs (app.core.servo.kp_sizing); None: not checked."""

    @property
    def thermal_margin(self) -> float:
        """rating / τ_rms − 1 (np.inf without load)."""
        if self.rms_torque_Nm == 0.0:
            return math.inf
        return self.continuous_torque_Nm / self.rms_torque_Nm - 1.0

    @property
    def holds_peaks(self) -> bool:
        return self.peak_margin >= self.margin

    @property
    def holds_thermal(self) -> bool:
        return self.thermal_margin >= self.margin

    @property
    def holds_stiffness(self) -> bool:
        """A kp in the firmware's range gives the stiffness needed (True where not checked, or
        where the record has no motor law to check it with: said in the sizing's notes)."""
        return self.stiffness is None or self.stiffness.holds

    @property
    def holds(self) -> bool:
        return self.holds_peaks and self.holds_thermal and self.holds_stiffness

    def violations(self) -> list[str]:
        out = []
        if not self.holds_stiffness and self.stiffness is not None:
            out.append(self.stiffness.violation())
        if not self.holds_peaks:
            where = f"{self.work} " if self.work else ""
            out.append(
                f"peak: {where}sample {self.worst_sample} ({self.worst_torque_Nm:.3g} N·m at "
                f"{self.worst_speed_rad_s:.2g} rad/s) needs {1.0 / (1.0 + self.peak_margin):.2f}× "
                f"the envelope (margin {self.peak_margin:+.0%}, asked {self.margin:+.0%})"
            )
        if not self.holds_thermal:
            out.append(
                f"thermal: RMS {self.rms_torque_Nm:.3g} N·m"
                + (f" ({self.rms_work})" if self.rms_work else "")
                + " against "
                f"{self.continuous_torque_Nm:.3g} N·m continuous"
                + (" (assumed)" if self.continuous_assumed else "")
            )
        return out

    def to_json(self) -> dict[str, object]:
        return {
            "servo": self.servo,
            "holds": self.holds,
            "peak_margin": _finite(self.peak_margin),
            "worst_sample": self.worst_sample,
            "work": self.work or None,
            "rms_work": self.rms_work or None,
            "rms_torque_Nm": self.rms_torque_Nm,
            "continuous_torque_Nm": self.continuous_torque_Nm,
            "continuous_assumed": self.continuous_assumed,
            "thermal_margin": _finite(self.thermal_margin),
            "violations": self.violations(),
            **({} if self.stiffness is None else self.stiffness.to_json()),
        }


def _finite(value: float) -> float | None:
    return value if math.isfinite(value) else None


def check_margin(margin: float) -> float:
    if isinstance(margin, bool) or not isinstance(margin, int | float):
        raise SizingError(f"margin is {margin!r}; give a number ≥ 0")
    if not math.isfinite(margin) or margin < 0.0:
        raise SizingError(f"margin is {margin}; give a finite number ≥ 0 (0.3: 30 % headroom)")
    return float(margin)


def check_joint(
    record: ServoRecord,
    speed_rad_s: np.ndarray,
    torque_Nm: np.ndarray,
    duration_s: float,
    margin: float,
    env: Envelope | None = None,
    fraction: float = CONTINUOUS_FRACTION_OF_STALL,
) -> Check:
    """`record` on one joint's points, shape (T,) each; RMS over `duration_s` (samples equally
    spaced: the mean of τ²)."""
    env = envelope(record) if env is None else env
    rating, assumed = continuous_torque_Nm(record, fraction)
    if len(torque_Nm) == 0:
        return Check(record.key, math.inf, -1, 0.0, rating, assumed, margin)
    scale = env.scale(speed_rad_s, torque_Nm)
    worst = int(np.argmin(scale))
    rms = float(np.sqrt(np.mean(np.square(torque_Nm)))) if duration_s > 0 else 0.0
    return Check(
        record.key,
        float(scale[worst]) - 1.0,
        worst,
        rms,
        rating,
        assumed,
        margin,
        worst_torque_Nm=float(torque_Nm[worst]),
        worst_speed_rad_s=float(speed_rad_s[worst]),
    )


@dataclasses.dataclass(frozen=True)
class JointSizing:
    joint: str
    choice: str | None
    """The lightest (cheapest) servo that holds, None where none does."""
    checks: tuple[Check, ...]
    """Every candidate, in the catalogue's order."""

    def check(self, servo: str) -> Check:
        return next(c for c in self.checks if c.servo == servo)

    def to_json(self) -> dict[str, object]:
        chosen = None if self.choice is None else self.check(self.choice)
        best = max(self.checks, key=lambda c: min(c.peak_margin, c.thermal_margin))
        return {
            "joint": self.joint,
            "servo": self.choice,
            "kp": None if chosen is None or chosen.stiffness is None else chosen.stiffness.kp,
            "holds": self.choice is not None,
            "chosen": None if chosen is None else chosen.to_json(),
            "closest": None if chosen is not None else best.to_json(),
        }


@dataclasses.dataclass(frozen=True)
class Sizing:
    joints: tuple[JointSizing, ...]
    margin: float
    by: Criterion
    envelopes: dict[str, Envelope]
    notes: tuple[str, ...] = ()
    stiffness: dict[str, object] | None = None
    """How the kp were chosen (app.core.servo.kp_sizing), None where they were not."""

    @property
    def unsized(self) -> tuple[str, ...]:
        return tuple(j.joint for j in self.joints if j.choice is None)

    def to_json(self) -> dict[str, object]:
        return {
            "margin": self.margin,
            "by": self.by,
            "joints": [j.to_json() for j in self.joints],
            "unsized": list(self.unsized),
            "envelopes": {
                k: {**dataclasses.asdict(e), "torque_limit_Nm": _finite(e.torque_limit_Nm)}
                for k, e in self.envelopes.items()
            },
            "notes": list(self.notes),
            "stiffness": self.stiffness,
        }


def cost(record: ServoRecord, by: Criterion) -> float:
    """What sizing minimises: the record's mass or price (inf where it has none)."""
    return _cost(record, by)


def _cost(record: ServoRecord, by: Criterion) -> float:
    value = record.mass_kg if by == "mass" else record.price
    return math.inf if value is None else value


def size_joints(
    joint_names: Sequence[str],
    speed_rad_s: np.ndarray,
    torque_Nm: np.ndarray,
    duration_s: float,
    catalogue: dict[str, ServoRecord],
    margin: float = 0.3,
    by: Criterion = "mass",
    sample_index: np.ndarray | None = None,
    continuous_fraction: float = CONTINUOUS_FRACTION_OF_STALL,
) -> Sizing:
    """Per joint, the servo of least `by` that holds every point (T, n) with `margin` and the
    RMS torque; ties by key. Servos without a price are not candidates when sizing by price.
    `sample_index` (T,) names each point's sample in the motion (default 0 … T−1);
    `continuous_fraction` of stall is the rating assumed where a record publishes none."""
    margin = check_margin(margin)
    fraction = check_fraction(continuous_fraction)
    if by not in ("mass", "price"):
        raise SizingError(f"sizing by {by!r}; give mass or price")
    w = np.asarray(speed_rad_s, dtype=float)
    tau = np.asarray(torque_Nm, dtype=float)
    n = len(joint_names)
    if w.shape != tau.shape or w.ndim != 2 or w.shape[1] != n:
        raise SizingError(f"points of shape {w.shape} and {tau.shape}; expected (T, {n}) each")
    if w.shape[0] == 0:
        raise SizingError("the motion has no torque–speed points to size against")
    if not (np.all(np.isfinite(w)) and np.all(np.isfinite(tau))):
        raise SizingError("the motion's speeds or torques hold NaN or infinite values")
    candidates = [r for r in catalogue.values() if math.isfinite(_cost(r, by))]
    notes = []
    if not candidates:
        raise SizingError(
            f"no servo in the catalogue has a {by}; add it to your records (--servos FILE)"
        )
    if len(candidates) < len(catalogue):
        notes.append(f"{len(catalogue) - len(candidates)} servo(s) without a {by} left out")
    envelopes = {r.key: envelope(r) for r in candidates}
    assumed = [r.key for r in candidates if r.continuous_torque_Nm is None]
    if assumed:
        notes.append(
            f"continuous rating assumed {fraction:g} × stall torque "
            f"(none published) for {', '.join(assumed)}"
        )
    ranked = sorted(candidates, key=lambda r: (_cost(r, by), r.key))
    joints = []
    for j, name in enumerate(joint_names):
        checks = tuple(
            check_joint(r, w[:, j], tau[:, j], duration_s, margin, envelopes[r.key], fraction)
            for r in candidates
        )
        if sample_index is not None:
            checks = tuple(
                dataclasses.replace(c, worst_sample=int(sample_index[c.worst_sample]))
                if c.worst_sample >= 0
                else c
                for c in checks
            )
        by_key = {c.servo: c for c in checks}
        choice = next((r.key for r in ranked if by_key[r.key].holds), None)
        joints.append(JointSizing(name, choice, checks))
    return Sizing(tuple(joints), margin, by, envelopes, tuple(notes))


def combine(sizings: dict[str, Sizing], catalogue: dict[str, ServoRecord]) -> Sizing:
    """One sizing over several motions (label → its sizing, same joints, margin and criterion):
    per servo and joint the smallest peak margin and the largest RMS torque over the motions,
    so a servo holds the joint when it holds every motion; the choice as in `size_joints`."""
    if not sizings:
        raise SizingError("no motion to size against")
    first = next(iter(sizings.values()))
    joints = []
    for j, joint in enumerate(first.joints):
        checks = []
        for check in joint.checks:
            per_work = [(label, s.joints[j].check(check.servo)) for label, s in sizings.items()]
            peak_label, peak = min(per_work, key=lambda item: item[1].peak_margin)
            rms_label, rms = max(per_work, key=lambda item: item[1].rms_torque_Nm)
            checks.append(
                dataclasses.replace(
                    peak, rms_torque_Nm=rms.rms_torque_Nm, work=peak_label, rms_work=rms_label
                )
            )
        ranked = sorted(
            (c for c in checks if c.holds),
            key=lambda c: (_cost(catalogue[c.servo], first.by), c.servo),
        )
        joints.append(JointSizing(joint.joint, ranked[0].servo if ranked else None, tuple(checks)))
    notes = tuple(dict.fromkeys(n for s in sizings.values() for n in s.notes))
    return Sizing(tuple(joints), first.margin, first.by, first.envelopes, notes)
