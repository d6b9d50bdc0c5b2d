"""GaitSettings: the symmetric-gait planner's parameters, with the paper's case as defaults.

Chen et al. 2023 (papers/symmetric-gait-dircon.txt), section 5.2: H = 0.72 s for one complete
gait (two steps) advancing 0.2 m, 38 knots + 2 virtual knots, foothold slack bounds
a = −0.05, b = 0.05 (eq. 5), weights K0 = 6.5, K1 = 3.0, K2 = 1.5 (eq. 7), μ = 0.6, swing foot
≤ 0.10 m, |τ| ≤ 13 N·m and |q̇| ≤ 6.28 rad/s (section 5.1).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

from app.core import input_gate
from app.core.errors import StudioError, refuse_unknown_keys

MIN_KNOTS = 5
MAX_ITER = 10_000
MAX_KNOTS = 160
"""More knots than this grow the NLP past minutes and gigabytes (400 knots: > 600 s, 2 GB).
Above 38 a first solve starts from the 38-knot optimum (mesh refinement, gait_problem.py).
Building the NLP grows with the knots only through its size: its derivatives come from
per-knot blocks differentiated once (nlp.py); `biped-studio bench --only plan_fine` measures
the 160-knot build and refined solve."""


class GaitSettingsError(StudioError):
    """Planner settings that cannot describe a gait (bounds crossed, NaN, too few knots)."""


@dataclasses.dataclass(frozen=True)
class GaitSettings:
    """Parameters of one gait plan. `knots` and `baseline` fix the NLP's structure; every other
    field is a slider that re-solves the same NLP."""

    slack_a: float = -0.05
    """Lower bound a of the foothold slack: x1 = (0.5 + slack0)(x0 + x2), a ≤ slack0 (eq. 5)."""
    slack_b: float = 0.05
    """Upper bound b of slack0; a and b lie in [−0.5, 0.5]."""
    K0: float = 6.5
    """Weight of the energy term K0·h·Σ‖u‖² [1/(N·m)²·s⁻¹]."""
    K1: float = 3.0
    """Weight of the foothold slack term K1·slack0²."""
    K2: float = 1.5
    """Weight of the smoothness term K2·Σ‖(x, u)_k − (x, u)_{k−1}‖²."""
    H_s: float = 0.72
    """Duration of the complete gait (two steps, LSP + RSP) [s]."""
    step_length_m: float = 0.2
    """Distance the complete gait (two steps) advances [m]: x2 − x0. Each step is about half."""
    swing_height_m: float = 0.10
    """Highest the swing foot's sole points may rise [m]."""
    swing_clearance_m: float = 0.04
    """Lowest the swing foot's sole points may be at mid-swing [m], capped at swing_height_m.
    Not in the paper, whose planner only caps the height: without it the optimum shuffles the
    foot a few millimetres above the floor."""
    knots: int = 38
    """Real knots of the three modes; two virtual knots are added at the touch-downs."""
    mu: float = 0.6
    """Friction coefficient of the ground."""
    tau_max_Nm: float = 13.0
    """Bound on every planar joint torque [N·m]."""
    qd_max: float = 6.28
    """Bound on every planar joint speed [rad/s]."""
    baseline: bool = False
    """The "original DIRCON" counterpart: no foothold slack, no equal durations, no state
    exchange, no smoothness term (section 5.3)."""
    max_iter: int = 1000
    """IPOPT iterations before the solve stops with the last iterate (not a gait)."""
    pelvis_height_ratio: float = dataclasses.field(
        default=0.985, metadata={"unit": "", "range": (0.5, 1.0)}
    )
    """Highest the base (pelvis) may be, as a fraction of its straight-leg standing height
    (unitless, range [0.5, 1.0], default 0.985 ≈ 1.6 cm lower on dircon_biped). Not in the
    paper: at 1.0 the optimum walks on straight, slightly hyperextended knees; 1–2 cm lower it
    walks with bent knees as the paper's robot does."""
    knee_flexion_min_rad: float = dataclasses.field(
        default=0.0, metadata={"unit": "rad", "range": (0.0, 1.5)}
    )
    """Smallest knee flexion at every knot [rad], range [0, 1.5], default 0 (the pelvis height
    already bends the knees). Flexion is the knee angle that moves the foot backwards, whatever
    the sign convention of the URDF."""
    touchdown_speed_max_mps: float = dataclasses.field(
        default=0.3, metadata={"unit": "m/s", "range": (0.01, 5.0)}
    )
    """Bound on every component (x, z) of the landing foot's heel and toe velocity just before
    touch-down [m/s], range [0.01, 5], default 0.3 (without it the foot lands at ~1 m/s)."""
    K_impact: float = dataclasses.field(default=10.0, metadata={"unit": "1/J", "range": (0, 1e3)})
    """Weight of the kinetic energy lost in the two touch-down impacts,
    K_impact·Σ ½ Δvᵀ M Δv [1/J], range [0, 1000], default 10 (not in the paper, whose cost
    ignores impacts)."""
    check_per_interval: int = dataclasses.field(
        default=8, metadata={"unit": "samples", "range": (1, 100)}
    )
    """Samples per collocation interval of the fine grid on which the result checks the bounds
    between knots (reported in GaitResult.bound_check), range [1, 100], default 8."""

    def validate(self) -> GaitSettings:
        """Raise GaitSettingsError naming the first bad field and what would be valid."""
        for field in dataclasses.fields(self):
            value = getattr(self, field.name)
            if isinstance(value, float) and not math.isfinite(value):
                raise GaitSettingsError(f"{field.name} is {value}; give a finite number")
        if not isinstance(self.knots, int) or isinstance(self.knots, bool):
            raise GaitSettingsError(f"knots = {self.knots!r}: give a whole number")
        if self.knots < MIN_KNOTS:
            raise GaitSettingsError(
                f"knots = {self.knots}: at least {MIN_KNOTS} knots are needed for three modes"
            )
        if self.knots > MAX_KNOTS:
            raise GaitSettingsError(
                f"knots = {self.knots}: at most {MAX_KNOTS} (the paper uses 38)"
            )
        if not -0.5 <= self.slack_a <= 0.5 or not -0.5 <= self.slack_b <= 0.5:
            raise GaitSettingsError(
                f"slack bounds a = {self.slack_a}, b = {self.slack_b} must lie in [−0.5, 0.5]"
            )
        if self.slack_a > self.slack_b:
            raise GaitSettingsError(
                f"slack bounds crossed: a = {self.slack_a} > b = {self.slack_b}; need a ≤ b"
            )
        if not self.baseline and not self.slack_a <= 0.0 <= self.slack_b:
            raise GaitSettingsError(
                f"slack bounds [{self.slack_a}, {self.slack_b}] exclude 0: with the joint states "
                "exchanged exactly at both touch-downs (eq. 6) and both soles flat there, the two "
                "steps are necessarily equal (slack0 = 0), so no gait fits; give a ≤ 0 ≤ b"
            )
        for name in ("K0", "K1", "K2"):
            if getattr(self, name) < 0.0:
                raise GaitSettingsError(f"{name} = {getattr(self, name)}: weights must be ≥ 0")
        positive = {
            "H_s": (0.1, 10.0),
            "swing_height_m": (0.005, 1.0),
            "mu": (0.01, 5.0),
            "tau_max_Nm": (1e-3, 1e4),
            "qd_max": (1e-3, 1e3),
        }
        for name, (lo, hi) in positive.items():
            value = getattr(self, name)
            if not lo <= value <= hi:
                raise GaitSettingsError(f"{name} = {value}: give a value in [{lo:g}, {hi:g}]")
        if not 0.0 <= self.swing_clearance_m <= 1.0:
            raise GaitSettingsError(
                f"swing_clearance_m = {self.swing_clearance_m}: give a value in [0, 1] m"
            )
        if not 0.0 <= self.step_length_m <= 1.5:
            raise GaitSettingsError(
                f"step_length_m = {self.step_length_m}: give a forward advance in [0, 1.5] m"
            )
        for field in dataclasses.fields(self):
            if "range" in field.metadata:
                lo, hi = field.metadata["range"]
                value = getattr(self, field.name)
                if not lo <= value <= hi:
                    unit = field.metadata["unit"]
                    raise GaitSettingsError(
                        f"{field.name} = {value}: give a value in [{lo:g}, {hi:g}] {unit}".rstrip()
                    )
        if not isinstance(self.check_per_interval, int) or isinstance(
            self.check_per_interval, bool
        ):
            raise GaitSettingsError(f"check_per_interval = {self.check_per_interval!r}: a count")
        if not isinstance(self.max_iter, int) or not 1 <= self.max_iter <= MAX_ITER:
            raise GaitSettingsError(
                f"max_iter = {self.max_iter}: give between 1 and {MAX_ITER} iterations"
            )
        return self

    @property
    def structure(self) -> tuple[int, bool]:
        """What fixes the NLP's shape: (knots, baseline)."""
        return self.knots, self.baseline

    @classmethod
    def from_mapping(
        cls, values: dict[str, object], source: str = "settings", base: GaitSettings | None = None
    ) -> GaitSettings:
        """Settings from a dict (e.g. a parsed plan.toml), refusing unknown keys and bad types;
        fields not given keep `base`'s values (default: the class defaults, the paper's)."""
        fields = {f.name: f for f in dataclasses.fields(cls)}
        refuse_unknown_keys(values, tuple(fields), GaitSettingsError, source)
        typed: dict[str, object] = {}
        for name, value in values.items():
            default = getattr(cls, name)
            if isinstance(default, bool):
                ok = isinstance(value, bool)
            elif isinstance(default, int):
                ok = isinstance(value, int) and not isinstance(value, bool)
            else:
                ok = isinstance(value, int | float) and not isinstance(value, bool)
                value = float(value) if ok else value  # type: ignore[arg-type]
            if not ok:
                kind = type(default).__name__
                raise GaitSettingsError(f"{source}: {name} = {value!r} is not a {kind}")
            typed[name] = value
        if base is not None:
            return dataclasses.replace(base, **typed).validate()  # type: ignore[arg-type]
        return cls(**typed).validate()  # type: ignore[arg-type]


def read_settings_toml(path: Path) -> dict[str, object]:
    """The key/value pairs of a plan.toml (keys are GaitSettings fields, checked by
    `GaitSettings.from_mapping`)."""
    return dict(input_gate.read_toml(path, GaitSettingsError))
