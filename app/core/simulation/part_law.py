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
- m6 friction (opt-in per joint): its budget recomputed every tick from the motor torque kt·I,
  the external torque (−bias + constraint forces, less the joint's own friction force, as
  BAM's MuJoCo controller computes it) and q̇, written into MuJoCo's frictionloss;
- the rotor's armature as the joint's MuJoCo armature (replacing the default).

Energy per joint (electrical in = I²R + motor's mechanical work), accumulated each tick from
V = τ_explicit·R/kt and I = (V − kt·q̇)/R: `PartLoop.energy`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from app.core.servo.motor_law import FrictionM6, m6_budget
from app.core.simulation.servo_law import ServoLaw, ServoLoop

if TYPE_CHECKING:
    from app.core.robot.model import RobotModel
    from app.core.servo.model import ServoModel
    from app.core.servo.parts import ServoParts


M6 = tuple(field.name for field in dataclasses.fields(FrictionM6))


@dataclasses.dataclass(frozen=True, eq=False, kw_only=True)
class PartLaw(ServoLaw):
    """The servo law of real parts: the ideal law's arrays plus the motors', shape (n,) each."""

    kt_Nm_per_A: np.ndarray
    R_ohm: np.ndarray
    current_limit_A: np.ndarray
    """np.inf where the firmware sets none."""
    armature_kgm2: np.ndarray
    frictionloss_Nm: np.ndarray
    m6_joints: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, dtype=int))
    """Indices of the joints whose friction is BAM's m6 (recomputed each tick)."""
    m6_params: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((0, len(M6))))
    """Their m6 parameters, shape (len(m6_joints), 11), columns in `M6` order."""
    has_part: np.ndarray | None = None
    """(n,) bool: the joints with a servo part (`mixed_servo_law`); None: every joint. The
    others tick the ideal servo's law with its damping, keep the model's own armature and
    friction, and draw no energy."""

    @property
    def in_mujoco(self) -> bool:
        """Whether MuJoCo's actuators can step it (`part_blocks`): not with m6 friction, whose
        budget follows each tick's constraint forces."""
        return len(self.m6_joints) == 0

    @property
    def back_emf_Nms_per_rad(self) -> np.ndarray:
        return self.kt_Nm_per_A**2 / self.R_ohm

    def set_joint_dynamics(self, model, dofs: np.ndarray) -> None:
        """Write the damping of every joint (the parts' back-EMF + viscous, the ideal law's
        τ_max/ω_max elsewhere) and the parts' armature and friction into a MuJoCo model's
        actuated dofs."""
        dofs = np.asarray(dofs)
        model.dof_damping[dofs] = self.damping_Nms_per_rad
        mine = slice(None) if self.has_part is None else self.has_part
        model.dof_armature[dofs[mine]] = self.armature_kgm2[mine]
        model.dof_frictionloss[dofs[mine]] = self.frictionloss_Nm[mine]


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
    m6 = [i for i, x in enumerate(p) if isinstance(x.friction, FrictionM6)]
    viscous = np.array(
        [
            x.friction.friction_viscous
            if isinstance(x.friction, FrictionM6)
            else x.friction.friction_viscous_Nms
            for x in p
        ]
    )
    base = np.array(  # m6: its budget at rest, unloaded, until the first tick
        [
            x.friction.friction_base + x.friction.friction_stribeck
            if isinstance(x.friction, FrictionM6)
            else x.friction.friction_base_Nm
            for x in p
        ]
    )
    friction = f"m6 friction on {len(m6)} joint(s), m1 elsewhere" if m6 else "m1 friction"
    return PartLaw(
        stiffness_Nm_per_rad=kt * vin * gain / r,
        half_backlash_rad=np.deg2rad(0.5 * np.array([x.dead_band_deg for x in p])),
        damping_Nms_per_rad=kt**2 / r + viscous,
        effort_Nm=np.minimum(stall, kt * limit),
        velocity_rad_s=np.full(len(p), np.inf),
        notes=(
            f"servo parts: BAM motor law ({friction}), " + ", ".join(sorted({x.servo for x in p})),
        ),
        kt_Nm_per_A=kt,
        R_ohm=r,
        current_limit_A=limit,
        armature_kgm2=np.array([x.motor.armature_kgm2 for x in p]),
        frictionloss_Nm=base,
        m6_joints=np.array(m6, dtype=int),
        m6_params=np.array(
            [[getattr(p[i].friction, name) for name in M6] for i in m6], dtype=float
        ).reshape(len(m6), len(M6)),
    )


def mixed_servo_law(ideal: ServoLaw, parts: ServoParts, joint_names: Sequence[str]) -> PartLaw:
    """The parts' law on their joints (`part_servo_law`) and the ideal servo's law (`ideal`,
    in `joint_names` order) on the others: a robot partly fitted with real servos."""
    names = tuple(joint_names)
    law = part_servo_law(parts)
    where = np.array([names.index(name) for name in parts.joint_names], dtype=int)
    has_part = np.zeros(len(names), dtype=bool)
    has_part[where] = True

    def merged(part: np.ndarray, other: np.ndarray | float) -> np.ndarray:
        out = np.array(np.broadcast_to(other, len(names)), dtype=float)
        out[where] = part
        return out

    return PartLaw(
        stiffness_Nm_per_rad=merged(law.stiffness_Nm_per_rad, ideal.stiffness_Nm_per_rad),
        half_backlash_rad=merged(law.half_backlash_rad, ideal.half_backlash_rad),
        damping_Nms_per_rad=merged(law.damping_Nms_per_rad, ideal.damping_Nms_per_rad),
        effort_Nm=merged(law.effort_Nm, ideal.effort_Nm),
        velocity_rad_s=merged(law.velocity_rad_s, ideal.velocity_rad_s),
        notes=(
            *ideal.notes,
            *law.notes,
            *(
                (f"{int((~has_part).sum())} joint(s) on the ideal servo (no energy counted)",)
                if not has_part.all()
                else ()
            ),
        ),
        kt_Nm_per_A=merged(law.kt_Nm_per_A, 1.0),  # placeholders: no current on ideal joints
        R_ohm=merged(law.R_ohm, 1.0),
        current_limit_A=merged(law.current_limit_A, np.inf),
        armature_kgm2=merged(law.armature_kgm2, 0.0),
        frictionloss_Nm=merged(law.frictionloss_Nm, 0.0),
        m6_joints=where[law.m6_joints],
        m6_params=law.m6_params,
        has_part=has_part,
    )


def law_with_parts(
    robot: RobotModel, servo: ServoModel, parts: ServoParts | None
) -> PartLaw | None:
    """The servo law a simulation of `robot` runs with `parts` on their joints and the virtual
    servos `servo` elsewhere; None without parts (the simulation then builds the virtual
    servos' law itself)."""
    if parts is None:
        return None
    from app.core.simulation.servo_law import robot_servo_law

    if parts.joint_names == robot.joint_names:
        return part_servo_law(parts)
    return mixed_servo_law(robot_servo_law(robot, servo), parts, robot.joint_names)


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
    """The part law ticking on a MuJoCo model and data (read each tick: the joints' speeds,
    and for m6 joints the forces; written: m6 joints' frictionloss) and accumulating energy.
    Per tick, with preallocated
    arrays: I = τ/kt − (kt/R)·q̇, P = V·I with V = τ·R/kt; the motor's work is P − I²R
    (V = R·I + kt·q̇ by construction)."""

    def __init__(
        self,
        law: PartLaw,
        dt_s: float,
        initial_command: np.ndarray,
        model: Any,
        data: Any,
        dofs: np.ndarray,
    ) -> None:
        super().__init__(law, dt_s, initial_command)
        self.part = law
        self.dt_s = dt_s
        self._model, self._data = model, data
        qvel = data.qvel
        self._m6 = law.m6_joints
        self._m6_dofs = np.asarray(dofs)[self._m6]
        kwargs: dict[str, Any] = {n: law.m6_params[:, i] for i, n in enumerate(M6)}
        self._m6_friction = FrictionM6(**kwargs)
        self._m6_slot = np.full(model.nv, -1, dtype=int)  # dof → its row among the m6 joints
        self._m6_slot[self._m6_dofs] = np.arange(len(self._m6))
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
        self.limited_ticks = 0  # ticks at which the current limit clipped a joint's torque
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
            lo, hi = emf - self._kt_limit, emf + self._kt_limit
            if (tau < lo).any() or (tau > hi).any():
                self.limited_ticks += 1
            np.clip(tau, lo, hi, out=tau)
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
        if len(self._m6):
            self._update_m6(current, dq)
        return tau

    def account(self, tau: np.ndarray, dq: np.ndarray) -> None:
        """The energy of ticks stepped elsewhere (`part_blocks`): their torques τ (rows, n),
        already within the current limit, and the speeds q̇ (rows, n) they were applied at;
        the sums `torque` makes one tick at a time."""
        current = tau * self._inv_kt - dq * self._kt_over_r
        self._electrical += ((tau * self._r_over_kt) * current).sum(axis=0)
        self._sq += (current * current).sum(axis=0)
        np.maximum(self._peak, np.abs(current).max(axis=0, initial=0.0), out=self._peak)
        self._ticks += len(tau)

    def _update_m6(self, current: np.ndarray, dq: np.ndarray) -> None:
        """BAM's m6 budget of the m6 joints, into MuJoCo's frictionloss for the next step."""
        d, dofs, rows = self._data, self._m6_dofs, self._m6
        external = d.qfrc_constraint[dofs] - d.qfrc_bias[dofs]
        n = d.nefc
        if n:
            friction_rows = d.efc_type[:n] == 1  # mjCNSTR_FRICTION_DOF: id is the dof
            slots = self._m6_slot[d.efc_id[:n][friction_rows]]
            mine = slots >= 0
            np.subtract.at(external, slots[mine], d.efc_force[:n][friction_rows][mine])
        motor = self.part.kt_Nm_per_A[rows] * current[rows]
        loss, _ = m6_budget(self._m6_friction, motor, external, dq[rows])
        self._model.dof_frictionloss[dofs] = loss

    def energy(self) -> PartEnergy:
        dt, ticks = self.dt_s, max(self._ticks, 1)
        mask = 1.0 if self.part.has_part is None else self.part.has_part.astype(float)
        electrical = self._electrical * dt * mask
        joule = self._sq * self.part.R_ohm * dt * mask
        return PartEnergy(
            electrical_J=electrical,
            joule_J=joule,
            mechanical_J=electrical - joule,
            peak_current_A=self._peak * mask,
            rms_current_A=np.sqrt(self._sq / ticks) * mask,
            duration_s=self._ticks * dt,
        )
