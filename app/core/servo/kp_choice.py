"""One servo's firmware kp on one joint, as the sizing chose it (`kp_sizing`): the stiffness it
gives against what standing and the sag bound need. Its own module: a sizing Check
(`sizing`) carries one, and `kp_sizing` builds on `sizing`."""

from __future__ import annotations

import dataclasses
import math

__all__ = ["KpChoice"]


@dataclasses.dataclass(frozen=True)
class KpChoice:
    """One servo's kp on one joint (a sizing Check's stiffness)."""

    kp: float | None
    """The smallest whole kp giving need_Nm_per_rad; None: none in range (or not checked)."""
    kp_max: float
    per_kp_Nm_per_rad: float | None
    """K per unit of kp; None: the record has no motor law (not checked)."""
    need_Nm_per_rad: float
    stand_Nm_per_rad: float
    sag_Nm_per_rad: float
    peak_torque_Nm: float
    friction_Nm: float
    """The servo's friction at rest holding the peak load (app.core.servo.kp_sizing)."""
    max_sag_deg: float
    fit: str = "m1"
    """The fit whose kt, R and friction gave K and the sag: the one the joint's part runs."""
    stated: bool = False
    """A part with no kp law (app.core.servo.rated_point): no kp, its stiffness stated as the
    need (the P gain set to give it), `kp` None and `checked` False."""

    @property
    def checked(self) -> bool:
        return self.per_kp_Nm_per_rad is not None

    @property
    def holds(self) -> bool:
        return not self.checked or self.kp is not None

    @property
    def stiffness_Nm_per_rad(self) -> float | None:
        if self.stated:
            return self.stated_Nm_per_rad
        if self.kp is None or self.per_kp_Nm_per_rad is None:
            return None
        return self.kp * self.per_kp_Nm_per_rad

    @property
    def stated_Nm_per_rad(self) -> float:
        """The whole N·m/rad a part without a kp law is given: the need rounded up (≥ 1)."""
        return float(max(1, math.ceil(self.need_Nm_per_rad)))

    @property
    def sag_deg(self) -> float | None:
        k = self.stiffness_Nm_per_rad
        return None if not k else math.degrees((self.peak_torque_Nm + self.friction_Nm) / k)

    def violation(self) -> str:
        top = (self.per_kp_Nm_per_rad or 0.0) * self.kp_max
        why = (
            "stand" if self.stand_Nm_per_rad >= self.sag_Nm_per_rad else "sag"
        ) + f" {max(self.stand_Nm_per_rad, self.sag_Nm_per_rad):.3g}"
        return (
            f"stiffness: needs K ≥ {self.need_Nm_per_rad:.3g} N·m/rad ({why}; sag "
            f"≤ {self.max_sag_deg:g}° of {self.peak_torque_Nm + self.friction_Nm:.3g} N·m), "
            f"kp ≤ {self.kp_max:g} gives {top:.3g}"
        )

    def to_json(self) -> dict[str, object]:
        return {
            "kp": self.kp,
            "kp_max": self.kp_max,
            "stiffness_checked": self.checked,
            "stiffness_stated": self.stated,
            "stiffness_Nm_per_rad": self.stiffness_Nm_per_rad,
            "stiffness_need_Nm_per_rad": self.need_Nm_per_rad,
            "stand_need_Nm_per_rad": self.stand_Nm_per_rad,
            "sag_need_Nm_per_rad": self.sag_Nm_per_rad,
            "sag_deg": self.sag_deg,
            "fit": self.fit,
        }
