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
   `POST_FALL_S` (longer, up to `POST_FALL_MAX_S`, until a link other than a foot is on the
   floor: the run names the first one and when, `floor_link`) and stops; later samples
   repeat the last state.

Samples run a block at a time (no longer than `POST_FALL_S`, so a fall never needs a sample
the block has not made), each block's verdicts checked on its recorded rows (`recording`).
With the ideal servo in MuJoCo's actuators a block is two calls into C (`blocks`): every
physics tick in one `mujoco.rollout`, then the samples' forward passes batched; servo parts
too (`part_blocks`: their energy and current limit checked per tick on the rollout's states,
the samples that reach the limit in Python); a law in Python (`ServoLoop`, `PartLoop`: the
reference, and parts with m6 friction) steps tick by tick and records each sample after its
own forward pass. Both record at sample k the forces under the servo torque of the
step before it (the torque applied as the sample is taken).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from app.core.simulation.engine_io import EngineInput, EngineRun
from app.core.simulation.errors import SimulationDiverged, SimulationInputError
from app.core.simulation.part_law import PartLaw, PartLoop
from app.core.simulation.recording import (
    FALL_HEIGHT_FRACTION,
    FALL_TILT_DEG,
    MAX_SPEED,
    NON_FOOT_CLEARANCE_M,
    Recorder,
    Scene,
    check_diverged,
    diverged_message,
    first_fall,
    qpos_to_pin,
    qvel_to_pin,
    sensors_xml,
)
from app.core.simulation.servo_law import actuators_xml
from app.core.simulation.sim_model import SimModel
from app.core.simulation.stepper import Stepper

__all__ = [
    "DROP_M",
    "FALL_HEIGHT_FRACTION",
    "FALL_TILT_DEG",
    "MAX_SPEED",
    "NON_FOOT_CLEARANCE_M",
    "POST_FALL_S",
    "EngineInput",
    "EngineRun",
    "pin_to_qpos",
    "qpos_to_pin",
    "qvel_to_pin",
    "run_engine",
    "start",
]

DROP_M = 0.0005
POST_FALL_S = 0.5
POST_FALL_MAX_S = 2.0
"""After a fall with no link on the floor yet, the run goes on up to this long after the
fall [s] to see which link comes down first (then stops as after POST_FALL_S)."""


def pin_to_qpos(sim: SimModel, q_pin: np.ndarray, qpos: np.ndarray) -> None:
    """Write a pinocchio configuration into MuJoCo's qpos (in place)."""
    if sim.floating_base:
        qpos[:3] = q_pin[:3]
        qpos[3:7] = np.concatenate([q_pin[6:7], q_pin[3:6]])
    for i_pin, adr in sim.pin_scalar_q:
        qpos[adr] = q_pin[i_pin]
    for i_pin, adr in sim.pin_continuous_q:
        qpos[adr] = math.atan2(q_pin[i_pin + 1], q_pin[i_pin])


def run_engine(inp: EngineInput, progress: Callable[[float], None] | None = None) -> EngineRun:
    """Simulate the motion (module docstring). `progress(fraction)` is called at most about
    50 times (between blocks);
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
    law runs in Python) and the physics ticks per command sample. The model carries the
    recording's sensors (`recording.sensors_xml`), on as compiled; they change no physics."""
    import mujoco

    sim, law = inp.sim, inp.law
    extra, ctrl_joint = sensors_xml(sim), np.zeros(0, dtype=int)
    if inp.servo_in_mujoco and (law.in_mujoco if isinstance(law, PartLaw) else True):
        actuators, ctrl_joint = actuators_xml(law, sim.joint_names)
        extra += actuators
    head, tail = sim.xml.rsplit("</mujoco>", 1)
    m = mujoco.MjModel.from_xml_string(head + extra + "</mujoco>" + tail)
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
    """The module docstring's sequence: settle, then the samples a block at a time, each
    block's blow-up and fall verdicts checked on what it recorded."""
    begin = time.perf_counter()
    m, d, ctrl_joint, ticks = start(inp)
    stepper = Stepper(inp, m, d, ctrl_joint, ticks)
    stepper.settle()
    _check(d, -inp.settle_s)
    n_samples = len(stepper.commands)
    recorder = Recorder(
        m, d, Scene.of(inp.sim, m), n_samples, stepper.commands.shape[1], inp.dt_cmd_s
    )
    planned = (inp.roll_planned_rad, inp.pitch_planned_rad, inp.root_height_planned_m)
    post = max(1, round(POST_FALL_S / inp.dt_cmd_s))
    # A block no longer than the post-fall time: a fall found at a block's end never needs
    # samples the block has not simulated, nor stops before those it has.
    # A block per call into C: as long as that allows (Python's cost is per block).
    block, every = post, max(1, n_samples // 50)
    fall_index, reason, stop, k0, next_report = -1, "", n_samples, 0, 0
    while k0 < stop:
        if progress is not None and k0 >= next_report:
            progress(k0 / n_samples)
            next_report = k0 + every
        k1 = min(stop, k0 + block)
        stepper.block(k0, k1, recorder)
        check_diverged(recorder, k0, k1, inp.dt_cmd_s)
        if fall_index < 0 and inp.detect_falls:
            fall_index, reason = first_fall(recorder, k0, k1, inp.sim, planned)
            if fall_index >= 0:
                if fall_index == 0:
                    reason = f"while settling on the first pose: {reason}"
                stop = min(n_samples, fall_index + post)
        if (
            k1 == stop < n_samples
            and fall_index >= 0
            and recorder.first_touching(fall_index, k1) < 0
        ):
            # no link down yet: on until one is, or POST_FALL_MAX_S
            stop = min(n_samples, k1 + post, fall_index + round(POST_FALL_MAX_S / inp.dt_cmd_s))
        k0 = k1
    if progress is not None:
        progress(1.0)
    floor_index = recorder.first_touching(fall_index, stop) if fall_index >= 0 else -1
    return _engine_run(inp, recorder, stop - 1, (fall_index, reason, floor_index), stepper, begin)


def _engine_run(
    inp: EngineInput,
    recorder: Recorder,
    last: int,
    fall: tuple[int, str, int],
    stepper: Stepper,
    begin: float,
) -> EngineRun:
    """The recorded rows in the run's layouts; samples after `last` repeat it (no torque
    after the last recorded sample, as the step loop applies none). `fall`: the fall's
    sample, reason, and the first sample with a link on the floor (−1: none)."""
    rec, sim = recorder, inp.sim
    fall_index, reason, floor_index = fall
    rec.tau[last:] = 0.0
    for raw in (rec.qpos, rec.qvel, rec.xmat_root, rec.sole, rec.body_xpos, rec.touched_body):
        raw[last + 1 :] = raw[last]
    forces = rec.contact_forces(last + 1)
    forces = np.concatenate([forces, np.repeat(forces[last:], len(rec.tau) - last - 1, axis=0)])
    roll, pitch = rec.roll_pitch()
    R_world_base = rec.xmat_root.reshape(-1, 3, 3)
    return EngineRun(
        q=qpos_to_pin(sim, rec.qpos),
        v=qvel_to_pin(sim, rec.qvel, R_world_base),
        q_joints_rad=rec.qpos[:, sim.actuated_qpos],
        tau_Nm=rec.tau,
        roll_rad=roll,
        pitch_rad=pitch,
        contact_force_N=forces,
        sole_position_m=rec.sole,
        root_position_m=rec.body_xpos[:, rec.scene.root].copy(),
        non_foot_contact=rec.touching(),
        fall_index=fall_index,
        fall_reason=reason,
        floor_link=rec.touched_link(floor_index) if floor_index >= 0 else "",
        floor_link_index=floor_index,
        n_simulated=last + 1,
        wall_time_s=time.perf_counter() - begin,
        energy=stepper.servo.energy() if isinstance(stepper.servo, PartLoop) else None,
        balance_offsets_rad=None if stepper.balancer is None else stepper.balancer.offsets_rad,
    )


def _lowest_corner_z(d, m, geom: int) -> float:
    size = m.geom_size[geom]
    signs = np.array([[sx, sy, -1.0] for sx in (-1.0, 1.0) for sy in (-1.0, 1.0)])
    corners = d.geom_xpos[geom] + (d.geom_xmat[geom].reshape(3, 3) @ (signs * size).T).T
    return float(corners[:, 2].min())


def _check(d: Any, t_s: float) -> None:
    """MuJoCo resets the state when its accelerations turn NaN (mjWARN_BADQACC): a blow-up."""
    import mujoco

    reset = d.warning[mujoco.mjtWarning.mjWARN_BADQACC].number > 0
    if reset or not (np.all(np.isfinite(d.qpos)) and np.all(np.abs(d.qvel) < MAX_SPEED)):
        raise SimulationDiverged(diverged_message(t_s))
