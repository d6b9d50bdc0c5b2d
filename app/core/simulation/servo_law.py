"""The position servo as it is, per joint, in the simulation's step loop (numpy only).

Commands q_cmd arrive at the motion's sample rate (100 Hz) and are held (zero-order hold)
into the servo loop, which runs at the physics rate (1 kHz). Per joint, at each tick:

    s ← s + clip(q_cmd − s, −ω_max·Δt, +ω_max·Δt)        speed saturation of the set point
    e = s − q                                              position error [rad]
    τ_spring = K · dz(e, b/2),   dz(e, h) = sign(e)·max(|e| − h, 0)
    τ = clip(τ_spring, −τ_max, +τ_max) − D·q̇                torque and speed saturation

K = 1/c is the stiffness of the position loop (c the servo's true compliance, the same
`ServoModel.compliance_deg_per_Nm` the quasi-static model uses; a rigid servo, c = 0, gets
c = RIGID_COMPLIANCE_DEG_PER_NM), b the full width of the dead band (`ServoModel.backlash_deg`):
inside ±b/2 the gear train is loose and transmits no spring torque. D = τ_max/ω_max is a
DC motor's back-EMF damping (stall torque over no-load speed; Dynamixel XM430: 4.1 N·m over
4.8 rad/s = 0.85 N·m·s/rad, MuJoCo Menagerie's OP3 identifies 1.08): with the drive torque
saturated the joint follows a DC motor's torque-speed line τ = τ_max·(1 − q̇/ω_max), so no
joint turns faster than ω_max under its own drive. The damping term is MuJoCo's joint
damping (integrated implicitly, `mjcf`); the rest is computed here. τ_max and ω_max are the
URDF's effort and velocity limits (where the URDF gives none, the torque of the servo sized to
the robot, `app.core.servo.scaling`, or DEFAULT_EFFORT_NM, and DEFAULT_VELOCITY_RAD_S); D
follows from the τ_max the law uses.

At rest (q̇ = 0, |τ| < τ_max) under a load torque τ: q = q_cmd − c·τ − (b/2)·sign(τ),
exactly the quasi-static model of `app.core.servo.model`, so both take the same parameters.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

import numpy as np

from app.core.simulation.errors import SimulationInputError

if TYPE_CHECKING:  # the step loop's workers need numpy only, not pinocchio
    from app.core.robot.model import RobotModel
    from app.core.servo.model import ServoModel

RIGID_COMPLIANCE_DEG_PER_NM = 0.02
"""Compliance [°/(N·m)] given to a servo modelled as rigid (c = 0): K ≈ 2900 N·m/rad, stable
at a 1 ms step with the default armature."""
DEFAULT_EFFORT_NM = 20.0
"""Torque limit [N·m] of a joint whose URDF gives none (a large hobby servo's stall torque)."""
DEFAULT_VELOCITY_RAD_S = 6.0
"""Speed limit [rad/s] of a joint whose URDF gives none (about 57 rpm, a hobby servo's)."""


@dataclasses.dataclass(frozen=True, eq=False)
class ServoLaw:
    """Per-joint servo parameters in SI units, shape (n,) each (module docstring)."""

    stiffness_Nm_per_rad: np.ndarray
    half_backlash_rad: np.ndarray
    damping_Nms_per_rad: np.ndarray
    effort_Nm: np.ndarray
    velocity_rad_s: np.ndarray
    notes: tuple[str, ...] = ()

    def set_joint_dynamics(self, model, dofs: np.ndarray) -> None:
        """Write the law's back-EMF damping D into a MuJoCo model's actuated dofs (MuJoCo
        integrates it implicitly): the run's D is the law's, the one the drive torque
        compensates (`app.core.simulation.drive`)."""
        model.dof_damping[np.asarray(dofs)] = self.damping_Nms_per_rad


class ServoLoop:
    """The servo law ticking: set point, slew, drive torque, with preallocated arrays (the
    step loop calls it 1000 times per simulated second, so it avoids numpy temporaries)."""

    def __init__(self, law: ServoLaw, dt_s: float, initial_command: np.ndarray) -> None:
        self.law = law
        self.max_step = law.velocity_rad_s * dt_s
        self.setpoint = np.array(initial_command, dtype=float)
        self.command = self.setpoint.copy()
        self.settled = True
        self.has_play = bool(np.any(law.half_backlash_rad > 0.0))
        self.tau = np.zeros(len(self.setpoint))
        self._play = np.zeros(len(self.setpoint))
        self._lo_play, self._hi_play = -law.half_backlash_rad, law.half_backlash_rad
        self._lo_tau, self._hi_tau = -law.effort_Nm, law.effort_Nm

    def set_command(self, command: np.ndarray) -> None:
        """A new command arrives (it is then held)."""
        self.command = command
        self.settled = bool(np.array_equal(self.setpoint, command))

    def torque(self, q: np.ndarray) -> np.ndarray:
        """Drive torque [N·m] at joint positions q: slew the set point, then
        clip(K·dz(s − q, b/2), ±τ_max), with dz(e, h) = e − clip(e, −h, h)."""
        law = self.law
        if not self.settled:
            diff = self.command - self.setpoint
            if np.all(np.abs(diff) <= self.max_step):
                self.setpoint = np.array(self.command, dtype=float)
                self.settled = True
            else:
                self.setpoint += np.clip(diff, -self.max_step, self.max_step)
        # ufuncs with out= rather than np.clip: its Python wrapper costs more than the maths.
        e = np.subtract(self.setpoint, q, out=self.tau)
        if self.has_play:
            play = np.maximum(e, self._lo_play, out=self._play)
            e -= np.minimum(play, self._hi_play, out=play)
        e *= law.stiffness_Nm_per_rad
        np.maximum(e, self._lo_tau, out=e)
        return np.minimum(e, self._hi_tau, out=e)


def servo_damping_Nms_per_rad(effort_Nm: float | None, velocity_rad_s: float | None) -> float:
    """Back-EMF damping D = τ_max/ω_max [N·m·s/rad], defaults where the URDF gives none."""
    return (effort_Nm or DEFAULT_EFFORT_NM) / (velocity_rad_s or DEFAULT_VELOCITY_RAD_S)


def servo_law(
    servo: ServoModel,
    joint_names: tuple[str, ...],
    effort_Nm: list[float | None],
    velocity_rad_s: list[float | None],
    default_effort_Nm: float = DEFAULT_EFFORT_NM,
) -> ServoLaw:
    """The servo law of each joint from the virtual servos and the URDF's limits;
    default_effort_Nm [N·m] where the URDF gives no effort (the simulation passes the servo
    sized to the robot, `app.core.servo.scaling`)."""
    servos = servo.for_joints(joint_names)
    compliance = np.array(servos.compliance_deg_per_Nm, dtype=float)
    if np.any(compliance < 0.0):
        bad = joint_names[int(np.argmin(compliance))]
        raise SimulationInputError(
            f"the compliance of {bad} is negative; a servo's true compliance is ≥ 0 °/(N·m)"
        )
    notes = []
    missing = [
        n for n, e, v in zip(joint_names, effort_Nm, velocity_rad_s, strict=True) if not (e and v)
    ]
    if missing:
        notes.append(
            f"{len(missing)} joint(s) without URDF effort/velocity limits simulated with "
            f"{default_effort_Nm:.3g} N·m and {DEFAULT_VELOCITY_RAD_S:g} rad/s"
        )
    effort = np.array([e if e else default_effort_Nm for e in effort_Nm], dtype=float)
    velocity = np.array([v if v else DEFAULT_VELOCITY_RAD_S for v in velocity_rad_s], dtype=float)
    compliance_rad = np.deg2rad(np.where(compliance > 0.0, compliance, RIGID_COMPLIANCE_DEG_PER_NM))
    return ServoLaw(
        stiffness_Nm_per_rad=1.0 / compliance_rad,
        half_backlash_rad=np.deg2rad(0.5 * np.asarray(servos.backlash_deg, dtype=float)),
        damping_Nms_per_rad=effort / velocity,  # τ_max/ω_max with the defaults filled in
        effort_Nm=effort,
        velocity_rad_s=velocity,
        notes=tuple(notes),
    )


def robot_servo_law(robot: RobotModel, servo: ServoModel) -> ServoLaw:
    """The virtual servos' law on `robot`: its joints' efforts and speeds, the torque of the
    servo sized to the robot where the URDF gives no effort (what a run simulates, and what
    the drive torque compensates: `app.core.simulation.drive`)."""
    from app.core.servo.scaling import scaled_ideal_servo  # pinocchio: not in the workers

    return servo_law(
        servo,
        robot.joint_names,
        [joint.effort for joint in robot.joints],
        [joint.velocity for joint in robot.joints],
        scaled_ideal_servo(robot).torque_limit_Nm,  # where the URDF gives no effort
    )


def actuators_xml(law: ServoLaw, joint_names: tuple[str, ...]) -> tuple[str, np.ndarray]:
    """MuJoCo actuators applying the servo law's explicit part with ctrl = the set point s:
    per joint, `general` actuators of force K·s + b₀ − K·q clamped to a force range, so
    MuJoCo computes the torque in C at every step. Without play one actuator,
    clip(K·(s − q), ±τ_max); with play h = b/2 two, K·(s − h − q) clamped to [0, τ_max] and
    K·(s + h − q) clamped to [−τ_max, 0], whose sum is clip(K·dz(s − q, h), ±τ_max) (for
    e = s − q > h only the first acts, for e < −h only the second, inside ±h neither).
    Returns the `<actuator>` element and, per actuator, the index of its joint (ctrl = s[that])."""
    rows, joints = [], []
    for j, name in enumerate(joint_names):
        k = float(law.stiffness_Nm_per_rad[j])
        h = float(law.half_backlash_rad[j])
        tau = float(law.effort_Nm[j])
        ranges = ((0.0, (-tau, tau)),) if h <= 0.0 else ((-h, (0.0, tau)), (h, (-tau, 0.0)))
        for shift, (lo, hi) in ranges:
            rows.append(
                f'<general joint="{name}" gainprm="{k!r}" biastype="affine" '
                f'biasprm="{k * shift!r} {-k!r} 0" forcelimited="true" '
                f'forcerange="{lo!r} {hi!r}"/>'
            )
            joints.append(j)
    return f"<actuator>{''.join(rows)}</actuator>", np.array(joints, dtype=int)


class Setpoints:
    """The set point's slew (the first line of the law) ahead of the physics: it depends on
    the commands alone, so a whole hold of `ticks` steps is computed at once.
    `hold(command, ticks)`: (ticks, n) set points, or None when s reaches the command on the
    first tick (then it stays there: the ctrl is constant over the hold). `moving`: after
    `hold` or `ramp`, the number of leading rows that differ from the command held (the rows
    after them all equal it)."""

    def __init__(self, law: ServoLaw, dt_s: float, initial_command: np.ndarray) -> None:
        self.max_step = law.velocity_rad_s * dt_s
        self.setpoint = np.array(initial_command, dtype=float)
        self.moving = 0
        self._reach: dict[int, np.ndarray] = {}
        self._on = -2  # the sample whose command the set point sits on (−2: none known)
        self._small: tuple[np.ndarray, np.ndarray] | None = None  # (commands, within a tick)

    def restart(self, setpoint: np.ndarray) -> None:
        """The set point is `setpoint` (a state stepped back to, or left by a law in Python),
        on no sample's command known."""
        self.setpoint = np.array(setpoint, dtype=float)
        self.moving, self._on = 0, -2

    def hold_sample(self, commands: np.ndarray, k: int, ticks: int) -> np.ndarray | None:
        """`hold(commands[k], ticks)`, with a shortcut for the usual sample: when the set
        point sits on commands[k − 1] and every joint's step to commands[k] is within one
        tick's slew (found for all samples at once), it reaches commands[k] on the first
        tick (None) without per-sample arithmetic. Same result as `hold`."""
        if self._small is None or self._small[0] is not commands:
            step = np.abs(np.diff(commands, axis=0)) <= self.max_step
            self._small = (commands, np.concatenate([[False], step.all(axis=1)]))
        if self._on == k - 1 and self._small[1][k]:
            self.setpoint = np.array(commands[k], dtype=float)
            self.moving, self._on = 0, k
            return None
        rows = self.hold(commands[k], ticks)
        self._on = k if rows is None or self.moving < ticks else -2
        return rows

    def changed(self, commands: np.ndarray, k: int) -> None:
        """commands[k] was changed in place (the balance feedback's offsets): `hold_sample`'s
        shortcut is judged again for samples k and k + 1."""
        if self._small is None or self._small[0] is not commands:
            return
        for i in (k, k + 1):
            if 0 < i < len(commands):
                step = np.abs(commands[i] - commands[i - 1])
                self._small[1][i] = bool((step <= self.max_step).all())

    def hold(self, command: np.ndarray, ticks: int) -> np.ndarray | None:
        """Set points of `ticks` ticks holding `command`: after i ticks
        s₀ + clip(c − s₀, ±i·ω_max·Δt) (the per-tick slew summed in closed form)."""
        diff = np.subtract(command, self.setpoint)
        gap = np.abs(diff)
        if (gap <= self.max_step).all():
            self.setpoint = np.array(command, dtype=float)
            self.moving = 0
            return None
        reach = self._reach.get(ticks)
        if reach is None:
            reach = self._reach[ticks] = np.arange(1, ticks + 1)[:, None] * self.max_step
        arrived = gap <= reach
        # ufuncs rather than np.clip / np.where's wrappers: this runs once per sample.
        slewed = np.minimum(np.maximum(diff, -reach), reach)
        slewed += self.setpoint
        rows = np.where(arrived, command, slewed)
        done = arrived.all(axis=1)
        self.moving = int(done.argmax()) if done[-1] else ticks
        self.setpoint = rows[-1].copy()
        return rows

    def ramp(self, start: np.ndarray, end: np.ndarray, ticks: int) -> np.ndarray:
        """Set points of `ticks` ticks whose command ramps from `start` to `end` (the command
        of tick i is start + i·(end − start)/ticks), each slewed from the one before."""
        step = (end - start) / ticks
        commands = start + np.arange(1, ticks + 1)[:, None] * step
        if np.all(np.abs(commands[0] - self.setpoint) <= self.max_step) and np.all(
            np.abs(step) <= self.max_step
        ):
            self.setpoint = commands[-1].copy()  # it follows the ramp exactly
            self.moving = ticks
            return commands
        rows = np.empty_like(commands)
        s = self.setpoint
        for i, command in enumerate(commands):
            s = s + np.clip(command - s, -self.max_step, self.max_step)
            rows[i] = s
        self.setpoint = s.copy()
        self.moving = ticks
        return rows
