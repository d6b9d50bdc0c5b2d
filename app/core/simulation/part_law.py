"""The simulation's servo law driven by the part (numpy only): BAM's motor law per joint.

`app.core.servo.motor_law` gives, at the output, τ = kt·(vin·duty − kt·q̇)/R with
duty = clip(error_gain·kp·e, ±max_pwm). Split as the ideal servo's law is split
(`servo_law`): the explicit part clip(K·dz(e, b/2), ±τ_s) with K = kt·vin·error_gain·kp/R and
τ_s = kt·vin·max_pwm/R, and the back-EMF −(kt²/R)·q̇ as MuJoCo joint damping (integrated
implicitly, stable at any gain), so the part law is the ideal servo's with the part's K, τ_s and
D = kt²/R, no set-point slew (the firmware's P loop sees the command as it comes), plus:

- the firmware current limit: |kt·(V − kt·q̇)/R| ≤ kt·I_lim, applied to the explicit part with
  the tick's q̇ (exact where q̇ is the step's);
- m1 friction: friction_base as MuJoCo's frictionloss, friction_viscous added to the damping;
- the rotor's armature as the joint's MuJoCo armature (replacing the default).

Energy per joint (electrical in = I²R + motor's mechanical work), accumulated each tick from
V = τ_explicit·R/kt and I = (V − kt·q̇)/R: `PartLoop.energy`.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

import numpy as np

from app.core.simulation.servo_law import ServoLaw, ServoLoop

if TYPE_CHECKING:
    from app.core.servo.parts import ServoParts


@dataclasses.dataclass(frozen=True, eq=False, kw_only=True)
class PartLaw(ServoLaw):
    """The servo law of real parts: the ideal law's arrays plus the motors', shape (n,) each."""

    kt_Nm_per_A: np.ndarray
    R_ohm: np.ndarray
    current_limit_A: np.ndarray
    """np.inf where the firmware sets none."""
    armature_kgm2: np.ndarray
    frictionloss_Nm: np.ndarray

    @property
    def back_emf_Nms_per_rad(self) -> np.ndarray:
        return self.kt_Nm_per_A**2 / self.R_ohm

    def set_joint_dynamics(self, model, dofs: np.ndarray) -> None:
        """Write the parts' armature, damping (back-EMF + viscous) and friction into a MuJoCo
        model's actuated dofs."""
        model.dof_armature[dofs] = self.armature_kgm2
        model.dof_damping[dofs] = self.damping_Nms_per_rad
        model.dof_frictionloss[dofs] = self.frictionloss_Nm


def part_servo_law(parts: ServoParts) -> PartLaw:
    """The law of each joint's part, in the parts' joint order."""
    p = parts.parts
    kt = np.array([x.motor.kt_Nm_per_A for x in p])
    r = np.array([x.motor.R_ohm for x in p])
    vin = np.array([x.firmware.vin_V for x in p])
    gain = np.array([x.firmware.error_gain * x.firmware.kp for x in p])
    max_pwm = np.array([x.firmware.max_pwm for x in p])
    limit = np.array(
        [np.inf if x.firmware.current_limit_A is None else x.firmware.current_limit_A for x in p]
    )
    stall = kt * vin * max_pwm / r
    return PartLaw(
        stiffness_Nm_per_rad=kt * vin * gain / r,
        half_backlash_rad=np.deg2rad(0.5 * np.array([x.dead_band_deg for x in p])),
        damping_Nms_per_rad=kt**2 / r + np.array([x.friction.friction_viscous_Nms for x in p]),
        effort_Nm=np.minimum(stall, kt * limit),
        velocity_rad_s=np.full(len(p), np.inf),
        notes=(
            "servo parts: BAM motor law (m1 friction), " + ", ".join(sorted({x.servo for x in p})),
        ),
        kt_Nm_per_A=kt,
        R_ohm=r,
        current_limit_A=limit,
        armature_kgm2=np.array([x.motor.armature_kgm2 for x in p]),
        frictionloss_Nm=np.array([x.friction.friction_base_Nm for x in p]),
    )


@dataclasses.dataclass(frozen=True)
class PartEnergy:
    """Energy per joint [J], shape (n,) each, over the recorded motion."""

    electrical_J: np.ndarray
    """∫ V·I dt: drawn from the supply (negative where the motor brakes as a generator)."""
    joule_J: np.ndarray
    """∫ I²R dt: heat in the windings."""
    mechanical_J: np.ndarray
    """∫ kt·I·q̇ dt: the motor's work on the joint (before friction)."""
    peak_current_A: np.ndarray
    rms_current_A: np.ndarray
    duration_s: float

    def to_json(self) -> dict[str, object]:
        return {
            "electrical_J": self.electrical_J.tolist(),
            "joule_J": self.joule_J.tolist(),
            "mechanical_J": self.mechanical_J.tolist(),
            "total_electrical_J": float(self.electrical_J.sum()),
            "peak_current_A": self.peak_current_A.tolist(),
            "rms_current_A": self.rms_current_A.tolist(),
            "duration_s": self.duration_s,
        }


class PartLoop(ServoLoop):
    """The part law ticking; reads the joints' speeds from `qvel[dofs]` each tick (MuJoCo's
    array, updated in place by mj_step) and accumulates energy. Per tick, with preallocated
    arrays: I = τ/kt − (kt/R)·q̇, P = V·I with V = τ·R/kt; the motor's work is P − I²R
    (V = R·I + kt·q̇ by construction)."""

    def __init__(
        self,
        law: PartLaw,
        dt_s: float,
        initial_command: np.ndarray,
        qvel: np.ndarray,
        dofs: np.ndarray,
    ) -> None:
        super().__init__(law, dt_s, initial_command)
        self.part = law
        self.dt_s = dt_s
        contiguous = len(dofs) > 0 and bool(np.all(np.diff(dofs) == 1))
        self._dq_view = qvel[dofs[0] : dofs[-1] + 1] if contiguous else None
        self._qvel, self._dofs = qvel, dofs
        self._kt_limit = law.kt_Nm_per_A * law.current_limit_A
        self._limited = bool(np.any(np.isfinite(law.current_limit_A)))
        self._inv_kt = 1.0 / law.kt_Nm_per_A
        self._kt_over_r = law.kt_Nm_per_A / law.R_ohm
        self._r_over_kt = law.R_ohm / law.kt_Nm_per_A
        n = len(self.setpoint)
        self._current, self._tmp = np.zeros(n), np.zeros(n)
        self.reset_energy()

    def reset_energy(self) -> None:
        n = len(self.setpoint)
        self._electrical, self._peak, self._sq = np.zeros(n), np.zeros(n), np.zeros(n)
        self._ticks = 0

    def torque(self, q: np.ndarray) -> np.ndarray:
        tau = super().torque(q)
        dq = self._qvel[self._dofs] if self._dq_view is None else self._dq_view
        tmp, current = self._tmp, self._current
        if self._limited:  # |τ_explicit − D·q̇| ≤ kt·I_lim
            emf = self.part.back_emf_Nms_per_rad * dq
            np.clip(tau, emf - self._kt_limit, emf + self._kt_limit, out=tau)
        np.multiply(tau, self._inv_kt, out=current)
        current -= np.multiply(dq, self._kt_over_r, out=tmp)
        np.multiply(tau, self._r_over_kt, out=tmp)  # V
        tmp *= current
        self._electrical += tmp
        np.multiply(current, current, out=tmp)
        self._sq += tmp
        np.abs(current, out=tmp)
        np.maximum(self._peak, tmp, out=self._peak)
        self._ticks += 1
        return tau

    def energy(self) -> PartEnergy:
        dt, ticks = self.dt_s, max(self._ticks, 1)
        electrical = self._electrical * dt
        joule = self._sq * self.part.R_ohm * dt
        return PartEnergy(
            electrical_J=electrical,
            joule_J=joule,
            mechanical_J=electrical - joule,
            peak_current_A=self._peak.copy(),
            rms_current_A=np.sqrt(self._sq / ticks),
            duration_s=self._ticks * dt,
        )
