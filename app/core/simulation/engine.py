"""The step loop: MuJoCo physics with the servo law at every tick (numpy and mujoco only).

`run_engine` takes only picklable values (`EngineInput`) and returns one (`EngineRun`), so it
can run in a worker process without pinocchio. Sequence:

1. the first configuration is put down so that the lowest sole corner is `DROP_M` above the
   floor, and the first command is held for `settle_s` (not recorded): the robot settles on
   its soles and its servos;
2. sample k of the motion is recorded at t_k = k·Δt_cmd, then command k is held for Δt_cmd
   (Δt_cmd / Δt_physics servo ticks, `servo_law`), or, with `linear_hold`, ramped to
   command k + 1 (a stiff servo turns a held 100 Hz staircase into torque spikes);
3. at every recorded sample the fall verdict is checked: a non-foot body's origin within
   `NON_FOOT_CLEARANCE_M` of the floor or a non-sole geom touching it (the link is named), the
   torso's roll or
   pitch more than `FALL_TILT_DEG` away from the plan's, or the root below
   `FALL_HEIGHT_FRACTION` of its planned height. After a fall the simulation goes on for
   `POST_FALL_S` and stops; later samples repeat the last state.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from app.core.quaternions import wxyz_to_xyzw
from app.core.simulation.errors import SimulationDiverged, SimulationInputError
from app.core.simulation.part_law import PartEnergy, PartLaw, PartLoop
from app.core.simulation.servo_law import ServoLaw, ServoLoop, Setpoints, actuators_xml
from app.core.simulation.sim_model import SimModel

DROP_M = 0.0005
FALL_TILT_DEG = 30.0
FALL_HEIGHT_FRACTION = 0.6
NON_FOOT_CLEARANCE_M = 0.005
POST_FALL_S = 0.5
MAX_SPEED = 1e3
"""Any generalised speed beyond this [m/s or rad/s] is a blown-up simulation."""


@dataclasses.dataclass(frozen=True, eq=False)
class EngineInput:
    sim: SimModel
    law: ServoLaw
    q0: np.ndarray
    """First configuration, pinocchio layout (nq,)."""
    q_cmd_rad: np.ndarray
    """Servo commands (T, n)."""
    dt_cmd_s: float
    settle_s: float
    root_height_planned_m: np.ndarray
    """Planned root height above the floor (T,), for the fall verdict."""
    roll_planned_rad: np.ndarray
    pitch_planned_rad: np.ndarray
    linear_hold: bool = False
    """Ramp the set point linearly from one command to the next instead of holding it."""
    on_floor: bool = True
    """Put the lowest sole corner `DROP_M` above the floor first (else start at q0 as is)."""
    detect_falls: bool = True
    servo_in_mujoco: bool = True
    """The ideal servo's torque computed by MuJoCo's actuators (`servo_law.actuators_xml`),
    several steps per call where the set point holds; False: the law in Python at every
    tick into `qfrc_applied` (`ServoLoop`, the reference the tests compare with). Servo
    parts (`PartLaw`) always run in Python."""


@dataclasses.dataclass(frozen=True, eq=False)
class EngineRun:
    q: np.ndarray
    """Configurations (T, nq), pinocchio layout."""
    v: np.ndarray
    """Velocities (T, nv), pinocchio layout (base twist in the base frame)."""
    q_joints_rad: np.ndarray
    tau_Nm: np.ndarray
    """Servo torques applied during the step that follows each sample (T, n)."""
    roll_rad: np.ndarray
    pitch_rad: np.ndarray
    contact_force_N: np.ndarray
    """Floor force on each sole, world frame (T, 2, 3)."""
    sole_position_m: np.ndarray
    """Sole centres in the world (T, 2, 3)."""
    root_position_m: np.ndarray
    """The root body's origin in the world (T, 3) [m], MuJoCo's `xpos`."""
    non_foot_contact: np.ndarray
    """(T,) bool."""
    fall_index: int
    """First sample at which the robot has fallen, −1 if never."""
    fall_reason: str
    n_simulated: int
    wall_time_s: float
    energy: PartEnergy | None = None
    """Per-joint energy over the recorded motion, with servo parts (`part_law`)."""


def pin_to_qpos(sim: SimModel, q_pin: np.ndarray, qpos: np.ndarray) -> None:
    """Write a pinocchio configuration into MuJoCo's qpos (in place)."""
    if sim.floating_base:
        qpos[:3] = q_pin[:3]
        qpos[3:7] = np.concatenate([q_pin[6:7], q_pin[3:6]])
    for i_pin, adr in sim.pin_scalar_q:
        qpos[adr] = q_pin[i_pin]
    for i_pin, adr in sim.pin_continuous_q:
        qpos[adr] = math.atan2(q_pin[i_pin + 1], q_pin[i_pin])


def qpos_to_pin(sim: SimModel, qpos: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """MuJoCo's qpos as a pinocchio configuration (into `out` when given)."""
    q = np.zeros(sim.nq_pin) if out is None else out
    if sim.floating_base:
        q[:3] = qpos[:3]
        q[3:7] = wxyz_to_xyzw(qpos[3:7])
    scalar, continuous = np.asarray(sim.pin_scalar_q), np.asarray(sim.pin_continuous_q)
    if len(scalar):
        q[scalar[:, 0]] = qpos[scalar[:, 1]]
    if len(continuous):
        angle = qpos[continuous[:, 1]]
        q[continuous[:, 0]], q[continuous[:, 0] + 1] = np.cos(angle), np.sin(angle)
    return q


def qvel_to_pin(
    sim: SimModel, qvel: np.ndarray, R_world_base: np.ndarray, out: np.ndarray | None = None
) -> np.ndarray:
    """MuJoCo's free joint has its linear velocity in the world, pinocchio's in the base."""
    v = np.zeros(sim.nv_pin) if out is None else out
    if sim.floating_base:
        v[:3] = R_world_base.T @ qvel[:3]
        v[3:6] = qvel[3:6]
    dofs = np.asarray(sim.pin_dof)
    if len(dofs):
        v[dofs[:, 0]] = qvel[dofs[:, 1]]
    return v


def run_engine(inp: EngineInput, progress: Callable[[float], None] | None = None) -> EngineRun:
    """Simulate the motion (module docstring). `progress(fraction)` is called about 50 times;
    raising from it stops the run. MuJoCo's warnings are kept in memory for the run (by
    default MuJoCo appends them to MUJOCO_LOG.TXT in the working folder); a blow-up is
    reported as SimulationDiverged."""
    import mujoco

    messages: list[str] = []  # MuJoCo's warning hook is process-wide: set for this run only
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(messages.append)
    try:
        return _run(inp, progress)
    finally:
        mujoco.set_mju_user_warning(previous)


def start(inp: EngineInput) -> tuple[Any, Any, np.ndarray, int]:
    """The run's MuJoCo model and data at its first configuration (put down on the floor with
    `on_floor`), the joint of each actuator's ctrl (`servo_law.actuators_xml`; none when the
    law runs in Python) and the physics ticks per command sample."""
    import mujoco

    sim, law = inp.sim, inp.law
    xml, ctrl_joint = sim.xml, np.zeros(0, dtype=int)
    if inp.servo_in_mujoco and not isinstance(law, PartLaw):
        actuators, ctrl_joint = actuators_xml(law, sim.joint_names)
        head, tail = xml.rsplit("</mujoco>", 1)
        xml = head + actuators + "</mujoco>" + tail
    m = mujoco.MjModel.from_xml_string(xml)
    law.set_joint_dynamics(m, sim.actuated_dof)  # its back-EMF (a part's rotor, friction)
    d = mujoco.MjData(m)
    dt = float(m.opt.timestep)
    ticks = round(inp.dt_cmd_s / dt)
    if ticks < 1 or abs(ticks * dt - inp.dt_cmd_s) > 1e-9 + 1e-6 * inp.dt_cmd_s:
        raise SimulationInputError(
            f"the motion's time step {inp.dt_cmd_s:g} s is not a multiple of the physics step "
            f"{dt:g} s; resample the motion"
        )
    pin_to_qpos(sim, inp.q0, d.qpos)
    mujoco.mj_forward(m, d)
    soles = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, name) for name in sim.sole_geoms]
    if sim.floating_base and inp.on_floor:
        d.qpos[2] += DROP_M - min(_lowest_corner_z(d, m, g) for g in soles)
        mujoco.mj_forward(m, d)
    return m, d, ctrl_joint, ticks


def _run(inp: EngineInput, progress: Callable[[float], None] | None) -> EngineRun:
    import mujoco

    begin = time.perf_counter()
    sim, law = inp.sim, inp.law
    m, d, ctrl_joint, ticks = start(inp)
    in_mujoco = len(ctrl_joint) > 0
    dt = float(m.opt.timestep)
    floor = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "floor")
    root = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, sim.root_body) if sim.floating_base else 0
    sites = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, name) for name in sim.sole_sites]
    side_of_body = {
        mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name): side
        for side, names in enumerate(sim.foot_bodies)
        for name in names
    }
    foot_bodies = set(side_of_body)
    # Every geom on a foot (its sole box, and its hull with `hulls`) counts for that foot.
    side_of_geom = {
        g: side_of_body[int(m.geom_bodyid[g])]
        for g in range(m.ngeom)
        if int(m.geom_bodyid[g]) in side_of_body
    }
    non_foot = np.array([b for b in range(1, m.nbody) if b not in foot_bodies], dtype=int)
    link_of = dict(sim.body_links)

    def link_name(body: int) -> str:
        name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, body) or f"body {body}"
        return link_of.get(name, name)

    aq, av = sim.actuated_qpos, sim.actuated_dof
    commands = np.asarray(inp.q_cmd_rad, dtype=float)
    n_samples, n = commands.shape
    servo = (
        PartLoop(law, dt, commands[0], m, d, av)
        if isinstance(law, PartLaw)
        else ServoLoop(law, dt, commands[0])
    )
    setpoints = Setpoints(law, dt, commands[0])
    # Contiguous actuated coordinates are read and written through views (no copies).
    qpos_view = d.qpos[aq[0] : aq[-1] + 1] if _contiguous(aq) else None
    qfrc_view = d.qfrc_applied[av[0] : av[-1] + 1] if _contiguous(av) else None

    def tick() -> None:
        tau = servo.torque(d.qpos[aq] if qpos_view is None else qpos_view)
        if qfrc_view is None:
            d.qfrc_applied[av] = tau
        else:
            qfrc_view[:] = tau
        mujoco.mj_step(m, d)

    def hold(rows: np.ndarray | None, command: np.ndarray, n_ticks: int) -> None:
        """MuJoCo's actuators: `n_ticks` steps at the set points `rows` (None: at `command`)."""
        if rows is None:
            d.ctrl[:] = command[ctrl_joint]
            mujoco.mj_step(m, d, n_ticks)
            return
        for row in rows[:, ctrl_joint]:
            d.ctrl[:] = row
            mujoco.mj_step(m, d)

    if in_mujoco:
        settle = round(inp.settle_s / dt)
        hold(setpoints.hold(commands[0], settle), commands[0], settle)
    else:
        for _ in range(round(inp.settle_s / dt)):
            tick()
    _check(d, m, -inp.settle_s)
    if isinstance(servo, PartLoop):
        servo.reset_energy()
    nq, nv = sim.nq_pin, sim.nv_pin
    out_q, out_v = np.zeros((n_samples, nq)), np.zeros((n_samples, nv))
    out_qj, out_tau = np.zeros((n_samples, n)), np.zeros((n_samples, n))
    roll, pitch = np.zeros(n_samples), np.zeros(n_samples)
    forces, sole_pos = np.zeros((n_samples, 2, 3)), np.zeros((n_samples, 2, 3))
    root_pos = np.zeros((n_samples, 3))
    touching = np.zeros(n_samples, dtype=bool)
    fall_index, reason, stop_index = -1, "", n_samples
    every = max(1, n_samples // 50)
    force6 = np.zeros(6)
    actuation_off = int(mujoco.mjtDisableBit.mjDSBL_ACTUATION)
    k = 0
    for k in range(n_samples):
        _check(d, m, k * inp.dt_cmd_s)
        if in_mujoco:  # the servo torque of the last step, as the Python law leaves it
            d.qfrc_applied[:] = d.qfrc_actuator
            m.opt.disableflags |= actuation_off
        mujoco.mj_forward(m, d)  # after mj_step, positions and contacts lag qpos by a step
        if in_mujoco:
            m.opt.disableflags &= ~actuation_off
            d.qfrc_applied[:] = 0.0
        R = d.xmat[root].reshape(3, 3) if sim.floating_base else np.eye(3)
        qpos_to_pin(sim, d.qpos, out_q[k])
        qvel_to_pin(sim, d.qvel, R, out_v[k])
        out_qj[k] = d.qpos[aq]
        roll[k] = math.atan2(R[2, 1], R[2, 2])
        pitch[k] = math.atan2(-R[2, 0], math.hypot(R[0, 0], R[1, 0]))
        for side in (0, 1):
            sole_pos[k, side] = d.site_xpos[sites[side]]
        root_pos[k] = d.xpos[root]
        touched = ""
        pairs = d.contact.geom  # (ncon, 2), read at once: d.contact[c] builds an object
        on_floor = np.flatnonzero((pairs == floor).any(axis=1))
        for c in on_floor.tolist():
            first_is_floor = int(pairs[c, 0]) == floor
            other = int(pairs[c, 1] if first_is_floor else pairs[c, 0])
            foot = side_of_geom.get(other)
            if foot is None:
                touching[k] = True
                touched = touched or link_name(int(m.geom_bodyid[other]))
                continue
            mujoco.mj_contactForce(m, d, c, force6)
            world = d.contact.frame[c].reshape(3, 3).T @ force6[:3]
            forces[k, foot] += world if first_is_floor else -world
        if non_foot.size and d.xpos[non_foot, 2].min() < NON_FOOT_CLEARANCE_M:
            touching[k] = True
            touched = touched or link_name(int(non_foot[np.argmin(d.xpos[non_foot, 2])]))
        if fall_index < 0 and inp.detect_falls:
            reason = _fall_reason(inp, k, roll[k], pitch[k], d.xpos[root, 2], touched, sim)
            if reason:
                fall_index = k
                if k == 0:
                    reason = f"while settling on the first pose: {reason}"
                stop_index = min(n_samples, k + max(1, round(POST_FALL_S / inp.dt_cmd_s)))
        if k + 1 >= stop_index:
            break
        if progress is not None and k % every == 0:
            progress(k / n_samples)
        if in_mujoco:
            if inp.linear_hold:
                hold(
                    setpoints.ramp(commands[k], commands[min(k + 1, n_samples - 1)], ticks),
                    commands[k],
                    ticks,
                )
            else:
                hold(setpoints.hold(commands[k], ticks), commands[k], ticks)
            out_tau[k] = d.qfrc_actuator[av]
            continue
        if inp.linear_hold:
            step = (commands[min(k + 1, n_samples - 1)] - commands[k]) / ticks
            for i in range(1, ticks + 1):
                servo.set_command(commands[k] + i * step)
                tick()
        else:
            servo.set_command(commands[k])
            for _ in range(ticks):
                tick()
        out_tau[k] = servo.tau
    last = k
    for array in (out_q, out_v, out_qj, out_tau, roll, pitch, forces, sole_pos, root_pos, touching):
        array[last + 1 :] = array[last]
    if progress is not None:
        progress(1.0)
    return EngineRun(
        q=out_q,
        v=out_v,
        q_joints_rad=out_qj,
        tau_Nm=out_tau,
        roll_rad=roll,
        pitch_rad=pitch,
        contact_force_N=forces,
        sole_position_m=sole_pos,
        root_position_m=root_pos,
        non_foot_contact=touching,
        fall_index=fall_index,
        fall_reason=reason,
        n_simulated=last + 1,
        wall_time_s=time.perf_counter() - begin,
        energy=servo.energy() if isinstance(servo, PartLoop) else None,
    )


def _contiguous(indices: np.ndarray) -> bool:
    return len(indices) > 0 and bool(np.all(np.diff(indices) == 1))


def _lowest_corner_z(d, m, geom: int) -> float:
    size = m.geom_size[geom]
    signs = np.array([[sx, sy, -1.0] for sx in (-1.0, 1.0) for sy in (-1.0, 1.0)])
    corners = d.geom_xpos[geom] + (d.geom_xmat[geom].reshape(3, 3) @ (signs * size).T).T
    return float(corners[:, 2].min())


def _check(d, m, t_s: float) -> None:
    """MuJoCo resets the state when its accelerations turn NaN (mjWARN_BADQACC): a blow-up."""
    import mujoco

    reset = d.warning[mujoco.mjtWarning.mjWARN_BADQACC].number > 0
    if reset or not (np.all(np.isfinite(d.qpos)) and np.all(np.abs(d.qvel) < MAX_SPEED)):
        raise SimulationDiverged(
            f"the simulation blew up at t = {t_s:.3f} s (NaN or runaway speed); the servos are "
            "too stiff for the time step: lower the stiffness or the time step"
        )


def _fall_reason(
    inp: EngineInput, k: int, roll: float, pitch: float, z: float, touched: str, sim: SimModel
) -> str:
    """Why sample k has fallen ("" if it has not); `touched`: the first non-foot link found
    on the floor at k ("" if none)."""
    if touched:
        return f"the link {touched} touches the floor"
    if not sim.floating_base:
        return ""
    for label, actual, planned in (
        ("roll", roll, inp.roll_planned_rad[k]),
        ("pitch", pitch, inp.pitch_planned_rad[k]),
    ):
        error = math.degrees(abs(math.remainder(actual - planned, 2.0 * math.pi)))
        if error > FALL_TILT_DEG:
            return f"the torso's {label} is {error:.0f}° off the plan"
    if z < FALL_HEIGHT_FRACTION * inp.root_height_planned_m[k]:
        return (
            f"the torso is down to {z * 100:.1f} cm "
            f"(planned {inp.root_height_planned_m[k] * 100:.1f} cm)"
        )
    return ""
