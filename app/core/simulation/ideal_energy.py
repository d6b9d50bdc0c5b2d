"""Electrical energy of a run on the ideal (virtual) servo, from a stated default motor.

The ideal servo (`servo_law`) has no motor, so a run on it draws no current. To set the
simulated walk's specific resistance beside the paper's Table 4 (the real robot's *measured
motor energy*), each joint is given a default DC motor, output-referred (torque constant kt
[N·m/A] at the joint, winding resistance R [Ω]), and the energy is computed post hoc from what
the run recorded, per joint j and sample interval k (the hold after sample k, dt long):

    τ_jk = τ_servo,jk − D_j·q̇_j,k+1     the servo's torque on the joint [N·m]: the recorded
                                        explicit part (`SimulationResult.tau_Nm`, the hold's
                                        last tick) less the back-EMF damping D of the law
                                        (MuJoCo's joint damping, not in the recorded column)
    mechanical   P_m = τ·q̇              q̇ at the hold's end, where τ is recorded: the step
                                        integrator's work τ·Δq/dt when one tick is one sample
    Joule        P_J = (τ/kt)²·R        I = τ/kt at the output
    electrical   P = max(P_m + P_J, 0)  no regeneration credit: a braking joint draws nothing
                                        and gives nothing back (a hobby servo's H-bridge
                                        burns it)
    E = Σ_k Σ_j P_jk·dt                 over the stretch simulated, up to the fall if it falls

The default motor (`default_motor`): per joint, the catalogue servo with an identified motor
model (BAM's m1/m6 fits: MX-64, MX-106, XL-320, XL330) whose datasheet stall torque is closest
in ratio to the joint's torque limit τ_max, behind a gearbox scaled so that its stall torque
is τ_max: kt → kt·r, R unchanged, r = τ_max / τ_stall (the same motor and winding, a taller
gear: the copper loss per N·m² falls as 1/r²). On servo_biped (τ_max 6 N·m): the MX-64
(7.3 N·m), r = 0.82. Roban S14's sized 57 N·m: the MX-106 (10 N·m), r = 5.7.

`run_ideal_sr` sets a run's SR from that energy, E / (M·g·d) over the distance d its root
covered along the planned direction up to its end or fall (a robot that tips sideways has
not walked the way it fell), beside the planned-work SR (`battery.positive_work_J` of the
feed-forward over the planned distance): one function for `simulate`, `plan --compare
--simulate` and the studio's Simulation rows.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np

from app.core.simulation.errors import SimulationInputError
from app.core.simulation.servo_law import ServoLaw, ServoLoop


@dataclasses.dataclass(frozen=True)
class DefaultMotor:
    """The stated motor behind each ideal servo, output-referred, shape (n,) each."""

    kt_Nm_per_A: np.ndarray
    R_ohm: np.ndarray
    text: str
    """Which catalogue servo and gear scaling, in one line."""


@dataclasses.dataclass(frozen=True)
class IdealEnergy:
    """Energy per joint [J], shape (n,) each, over the recorded motion (module docstring)."""

    mechanical_J: np.ndarray
    """∫ τ·q̇ dt, signed (braking subtracts)."""
    positive_work_J: np.ndarray
    """∫ max(τ·q̇, 0) dt."""
    joule_J: np.ndarray
    """∫ (τ/kt)²·R dt."""
    electrical_J: np.ndarray
    """∫ max(τ·q̇ + (τ/kt)²·R, 0) dt: drawn, no regeneration credit."""
    duration_s: float
    motor: str

    def to_json(self) -> dict[str, object]:
        return {
            "mechanical_J": self.mechanical_J.tolist(),
            "positive_work_J": self.positive_work_J.tolist(),
            "joule_J": self.joule_J.tolist(),
            "electrical_J": self.electrical_J.tolist(),
            "total_electrical_J": float(self.electrical_J.sum()),
            "total_mechanical_J": float(self.mechanical_J.sum()),
            "total_joule_J": float(self.joule_J.sum()),
            "duration_s": self.duration_s,
            "motor": self.motor,
            "regeneration": "not credited (P = max(τ·q̇ + I²R, 0) per joint and sample)",
        }


def default_motor(effort_Nm: np.ndarray, catalogue: dict | None = None) -> DefaultMotor:
    """Per joint of torque limit `effort_Nm` (n,) [N·m], the identified catalogue servo whose
    stall torque is closest in ratio, its gear scaled to that limit (module docstring)."""
    from app.core.servo.catalogue import load_catalogue

    fits = {
        r.key: (r, fit)
        for r in (load_catalogue() if catalogue is None else catalogue).values()
        if (fit := r.fit()) is not None and r.firmware is not None and r.stall_torque_Nm
    }
    if not fits:
        raise SimulationInputError("no catalogue servo has a motor model for the default motor")
    effort = np.asarray(effort_Nm, dtype=float)
    kt, r_ohm = np.empty(len(effort)), np.empty(len(effort))
    used: dict[tuple[str, float, float], int] = {}
    for j, tau_max in enumerate(effort):
        if not (math.isfinite(tau_max) and tau_max > 0.0):
            raise SimulationInputError(f"joint {j}: torque limit {tau_max} N·m; give one > 0")
        record, fit = min(
            fits.values(), key=lambda rf: abs(math.log((rf[0].stall_torque_Nm or 1.0) / tau_max))
        )
        motor, stall = fit.motor, float(record.stall_torque_Nm or 0.0)
        ratio = tau_max / stall
        kt[j], r_ohm[j] = motor.kt_Nm_per_A * ratio, motor.R_ohm
        used.setdefault((record.key, stall, round(ratio, 3)), 0)
        used[(record.key, stall, round(ratio, 3))] += 1
    text = "; ".join(
        f"{count} joint(s): {key} ({stall:g} N·m) geared ×{ratio:g}"
        for (key, stall, ratio), count in used.items()
    )
    return DefaultMotor(kt, r_ohm, f"default motor per joint: {text}")


def ideal_servo_energy(
    tau_Nm: np.ndarray, dq_rad_s: np.ndarray, dt_s: float, motor: DefaultMotor
) -> IdealEnergy:
    """Energy of the servo torques `tau_Nm` (T−1, n) [N·m], each held over a dt_s interval
    at the joint speeds `dq_rad_s` (T−1, n) [rad/s] (module docstring)."""
    tau, dq = np.asarray(tau_Nm, dtype=float), np.asarray(dq_rad_s, dtype=float)
    if tau.shape != dq.shape or tau.ndim != 2 or tau.shape[1] != len(motor.kt_Nm_per_A):
        raise SimulationInputError(f"torques {tau.shape} and speeds {dq.shape} do not match")
    mechanical = tau * dq
    joule = (tau / motor.kt_Nm_per_A) ** 2 * motor.R_ohm
    return IdealEnergy(
        mechanical_J=mechanical.sum(axis=0) * dt_s,
        positive_work_J=np.maximum(mechanical, 0.0).sum(axis=0) * dt_s,
        joule_J=joule.sum(axis=0) * dt_s,
        electrical_J=np.maximum(mechanical + joule, 0.0).sum(axis=0) * dt_s,
        duration_s=len(tau) * dt_s,
        motor=motor.text,
    )


def energy_until_s(result) -> float:
    """The end of the stretch a run's energy covers [s]: its fall, else all it simulated
    (after a fall the physics runs on a little, and the robot lies on the floor)."""
    return result.fall_time_s if result.fell else result.simulated_until_s


def run_ideal_energy(
    result,
    law: ServoLaw,
    joint_dofs: np.ndarray,
    motor: DefaultMotor,
    physics_dt_s: float = 0.001,
    linear_hold: bool = False,
) -> IdealEnergy:
    """`ideal_servo_energy` of a `SimulationResult` on the ideal servo `law`, at the physics
    ticks (physics_dt_s apart) of the samples simulated: the joints' path between samples is
    the cubic Hermite of the recorded angles `q_joints_rad` and speeds `v[:, joint_dofs]`,
    and the torque at each tick the law's (`ServoLoop`, the recorded commands held or ramped
    as the run held them) less D·q̇ (module docstring)."""
    t = result.t
    done = int(np.searchsorted(t, energy_until_s(result), side="right"))
    dt = float(t[1] - t[0])
    ticks = round(dt / physics_dt_s)
    h = dt / ticks
    q, v, cmd = result.q_joints_rad, result.v[:, joint_dofs], result.q_cmd_rad
    loop = ServoLoop(law, h, cmd[0])
    s = np.arange(ticks + 1) / ticks  # tick boundaries within a sample interval
    h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
    h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
    d00, d10 = (6 * s**2 - 6 * s) / dt, 3 * s**2 - 4 * s + 1
    d01, d11 = (-6 * s**2 + 6 * s) / dt, 3 * s**2 - 2 * s
    n_ticks = (done - 1) * ticks
    tau = np.empty((n_ticks, q.shape[1]))
    dq = np.empty_like(tau)
    for k in range(done - 1):
        path = np.outer(h00, q[k]) + np.outer(h10 * dt, v[k])
        path += np.outer(h01, q[k + 1]) + np.outer(h11 * dt, v[k + 1])
        speed = np.outer(d00, q[k]) + np.outer(d10, v[k])
        speed += np.outer(d01, q[k + 1]) + np.outer(d11, v[k + 1])
        after = cmd[min(k + 1, len(cmd) - 1)]
        if not linear_hold:
            loop.set_command(cmd[k])
        for i in range(ticks):
            if linear_hold:
                loop.set_command(cmd[k] + (i + 1) * (after - cmd[k]) / ticks)
            row = k * ticks + i
            tau[row] = loop.torque(path[i])
            # the step's mean speed (the work τ·Δq) and the damping at its end (implicit)
            dq[row] = (path[i + 1] - path[i]) / h
            tau[row] -= law.damping_Nms_per_rad * speed[i + 1]
    return ideal_servo_energy(tau, dq, h, motor)


@dataclasses.dataclass(frozen=True)
class IdealSR:
    """A run's electrical energy on the ideal servo and its specific resistances."""

    energy: IdealEnergy
    until_s: float
    """The end of the stretch the energy covers [s] (`energy_until_s`)."""
    fell: bool
    distance_m: float
    """The root's displacement along the planned direction up to `until_s` [m] (its
    horizontal displacement for a motion in place)."""
    planned_distance_m: float
    planned_work_J: float | None
    """The feed-forward's positive work along the plan; None for a motion in place."""
    sr_electrical: float | None
    """E / (M·g·d); None below `battery.MIN_DISTANCE_M` covered."""
    sr_planned: float | None

    def to_json(self) -> dict[str, object]:
        """`simulate --json`'s `ideal_servo_energy`."""
        return {
            **self.energy.to_json(),
            "until_s": self.until_s,
            "fell": self.fell,
            "distance_m": self.distance_m,
            "planned_distance_m": self.planned_distance_m,
            "planned_work_J": self.planned_work_J,
            "sr_electrical": self.sr_electrical,
            "sr_planned": self.sr_planned,
        }


def run_ideal_sr(
    result,
    robot,
    trajectory,
    law: ServoLaw,
    planned_tau: Callable[[], np.ndarray | None],
    physics_dt_s: float = 0.001,
    linear_hold: bool = False,
) -> IdealSR:
    """`run_ideal_energy` of a `SimulationResult` of `trajectory` on `robot`'s ideal servo
    `law` (the default motor sized to its torque limits) and its SR beside the planned one;
    `planned_tau()` [N·m] (T, n) is asked for only when the plan travels
    (`battery.MIN_DISTANCE_M`), None: no planned SR."""
    from app.core.simulation.battery import (
        MIN_DISTANCE_M,
        horizontal_travel_m,
        positive_work_J,
        specific_resistance,
        travel_along_plan_m,
    )

    dofs = np.array([joint.idx_v for joint in robot.joints])
    energy = run_ideal_energy(
        result, law, dofs, default_motor(law.effort_Nm), physics_dt_s, linear_hold
    )
    gravity = float(np.linalg.norm(robot.model.gravity.linear))
    until = energy_until_s(result)
    xy = result.q[result.t <= until, :2]
    distance = travel_along_plan_m(xy, trajectory.q[:, :2])
    planned = horizontal_travel_m(trajectory.q[:, :2])
    tau = planned_tau() if planned >= MIN_DISTANCE_M else None
    work = None if tau is None else positive_work_J(tau, trajectory.v[:, dofs], trajectory.dt)
    return IdealSR(
        energy=energy,
        until_s=until,
        fell=result.fell,
        distance_m=distance,
        planned_distance_m=planned,
        planned_work_J=work,
        sr_electrical=specific_resistance(
            float(energy.electrical_J.sum()), robot.mass_kg, distance, gravity
        ),
        sr_planned=None
        if work is None
        else specific_resistance(work, robot.mass_kg, planned, gravity),
    )
