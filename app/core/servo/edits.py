"""One edit of one joint's compensation or virtual-servo value, as a typed record.

The studio's Compensation panel makes one record per change (`SetK("left_knee", 1.4)`); the
record checks its value (a crafted client can send any) and makes the new coefficients and
servos from the old ones, which are never changed in place.
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar

import numpy as np

from app.core.errors import StudioError
from app.core.servo.compensation import MAX_ABS_K_DEG_PER_NM, MAX_PHI_DEG, CompensationParams
from app.core.servo.model import ServoModel

MAX_BACKLASH_DEG = 20.0
"""The widest dead band a virtual servo may be given [°]."""


class EditRefused(StudioError):
    """A value out of its range, or for a joint the robot does not have."""


@dataclasses.dataclass(frozen=True)
class JointEdit:
    """A new value for one joint; subclasses say which value and its range."""

    joint: str
    value: float
    NAME: ClassVar[str] = ""
    LIMITS: ClassVar[tuple[float, float]] = (0.0, 0.0)

    def check(self) -> None:
        """Raise EditRefused when the value is not a number in LIMITS."""
        low, high = self.LIMITS
        value = self.value
        if not (isinstance(value, int | float) and low <= float(value) <= high):
            raise EditRefused(f"{self.NAME} = {value!r}: give a value in [{low:g}, {high:g}]")

    def apply(
        self, params: CompensationParams, servo: ServoModel
    ) -> tuple[CompensationParams, ServoModel]:
        """The coefficients and servos with this value changed (checked first)."""
        self.check()
        if self.joint not in params.joint_names:
            raise EditRefused(f"no joint {self.joint!r} on this robot")
        i = params.joint_names.index(self.joint)
        k, phi = params.k_deg_per_Nm.copy(), params.phi_deg.copy()
        enabled = params.enabled.copy()
        compliance, backlash = servo.compliance_deg_per_Nm.copy(), servo.backlash_deg.copy()
        self._set(i, k=k, phi=phi, enabled=enabled, compliance=compliance, backlash=backlash)
        return (
            dataclasses.replace(params, k_deg_per_Nm=k, phi_deg=phi, enabled=enabled),
            ServoModel(servo.joint_names, compliance, backlash),
        )

    def _set(self, i: int, **columns: np.ndarray) -> None:
        columns[self.NAME][i] = float(self.value)


@dataclasses.dataclass(frozen=True)
class SetEnabled(JointEdit):
    """Compensate the joint (1) or command it as planned (0)."""

    NAME: ClassVar[str] = "enabled"
    LIMITS: ClassVar[tuple[float, float]] = (0.0, 1.0)

    def _set(self, i: int, **columns: np.ndarray) -> None:
        columns["enabled"][i] = bool(self.value)


@dataclasses.dataclass(frozen=True)
class SetK(JointEdit):
    """Spring compensation coefficient k of eq 7 [°/(N·m)]."""

    NAME: ClassVar[str] = "k"
    LIMITS: ClassVar[tuple[float, float]] = (-MAX_ABS_K_DEG_PER_NM, MAX_ABS_K_DEG_PER_NM)


@dataclasses.dataclass(frozen=True)
class SetPhi(JointEdit):
    """Clearance compensation angle φ of eq 23 [°]."""

    NAME: ClassVar[str] = "phi"
    LIMITS: ClassVar[tuple[float, float]] = (0.0, MAX_PHI_DEG)


@dataclasses.dataclass(frozen=True)
class SetCompliance(JointEdit):
    """The virtual servo's true compliance [°/(N·m)]."""

    NAME: ClassVar[str] = "compliance"
    LIMITS: ClassVar[tuple[float, float]] = (-MAX_ABS_K_DEG_PER_NM, MAX_ABS_K_DEG_PER_NM)


@dataclasses.dataclass(frozen=True)
class SetBacklash(JointEdit):
    """Full width of the virtual servo's dead band [°]."""

    NAME: ClassVar[str] = "backlash"
    LIMITS: ClassVar[tuple[float, float]] = (0.0, MAX_BACKLASH_DEG)
