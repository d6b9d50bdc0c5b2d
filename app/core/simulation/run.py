"""Simulate a motion on the robot's servos: checked inputs in, a typed result out.

`simulate` runs one command sequence; `simulate_plan_and_compensated` runs the plan as it is
(q_cmd = q_plan) and the compensated command (eq 7 / eq 23, `compensated_command`) side by
side, in two processes when the machine has the cores for it.
"""

from __future__ import annotations

import math
import multiprocessing
import os
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pinocchio as pin

from app.core.motions.trajectory import Trajectory
from app.core.parent_watch import die_with_parent
from app.core.robot.model import RobotModel
from app.core.servo.compensation import CompensationParams, compensated_command
from app.core.servo.model import ServoModel, base_roll_pitch, joint_angles
from app.core.simulation.balance_feedback import LABEL as BALANCE_LABEL
from app.core.simulation.balance_feedback import BalanceGains, balance_feedback
from app.core.simulation.engine import EngineInput, EngineRun, run_engine
from app.core.simulation.errors import SimulationInputError
from app.core.simulation.mjcf import SimOptions, build_sim_model
from app.core.simulation.result import SimulationResult, slip_m
from app.core.simulation.servo_law import ServoLaw, robot_servo_law
from app.core.simulation.sim_model import SimModel
from app.core.simulation.verdicts import judge
from app.core.simulation.worker import SimulationJob

GRAVITY_MPS2 = 9.81
CONTACT_LOAD_FRACTION = 0.02
"""A sole carrying more than this fraction of the weight is in contact (slip anchors)."""

SETTLE_S = 1.0
"""The first command is held this long before the motion starts [s]."""
LIMIT_TOLERANCE_RAD = 1e-6
PARALLEL_MIN_SIMULATED_S = 60.0
"""Total simulated time [s] from which runs go to worker processes by default (below it the
process start-up costs more than it saves)."""


def prepare(
    robot: RobotModel,
    trajectory: Trajectory,
    q_cmd_rad: np.ndarray,
    servo: ServoModel,
    options: SimOptions | None = None,
    sim: SimModel | None = None,
    settle_s: float = SETTLE_S,
    law: ServoLaw | None = None,
    balance: BalanceGains | None = None,
) -> EngineInput:
    """Check the inputs and make the step loop's (picklable) input. `sim` saves rebuilding
    the MuJoCo model when several commands run on one robot; `law` replaces the virtual
    servos' (e.g. `part_servo_law` of real servo parts); `balance`: run the balance feedback
    with these gains (`balance_feedback`; None: off)."""
    if tuple(trajectory.joint_names) != robot.joint_names:
        raise SimulationInputError(
            f"motion {trajectory.name!r} was made for other joints than {robot.name}'s; "
            "generate or import it for this robot"
        )
    if trajectory.q.shape[1] != robot.model.nq:
        raise SimulationInputError(f"motion {trajectory.name!r} does not fit {robot.name}")
    if not robot.floating_base:
        raise SimulationInputError(
            f"{robot.name} is fixed to the world; only a free-standing robot can be simulated"
        )
    q_cmd = np.asarray(q_cmd_rad, dtype=float)
    shape = (trajectory.n_samples, robot.n_actuated)
    if q_cmd.shape != shape:
        raise SimulationInputError(
            f"commands have shape {q_cmd.shape}; expected {shape}: one per sample and joint"
        )
    if not np.all(np.isfinite(q_cmd)):
        k, j = np.argwhere(~np.isfinite(q_cmd))[0]
        raise SimulationInputError(
            f"command of {robot.joint_names[j]} at sample {k} is {q_cmd[k, j]}; give finite values"
        )
    lower = np.array([joint.lower for joint in robot.joints]) - LIMIT_TOLERANCE_RAD
    upper = np.array([joint.upper for joint in robot.joints]) + LIMIT_TOLERANCE_RAD
    outside = (q_cmd < lower) | (q_cmd > upper)
    if np.any(outside):
        k, j = np.argwhere(outside)[0]
        joint, command = robot.joints[j], float(q_cmd[k, j])
        side, limit = ("upper", joint.upper) if command > joint.upper else ("lower", joint.lower)
        raise SimulationInputError(
            f"{int(outside.sum())} command(s) outside the joint limits, first {joint.name} at "
            f"t = {trajectory.t[k]:.2f} s: {math.degrees(command):.4g}°, "
            f"{math.degrees(abs(command - limit)):.2g}° beyond its {side} limit of "
            f"{math.degrees(limit):.1f}° (range [{math.degrees(joint.lower):.1f}°, "
            f"{math.degrees(joint.upper):.1f}°]; a large k can push a command out)"
        )
    if not (math.isfinite(settle_s) and 0.0 <= settle_s <= 10.0):
        raise SimulationInputError(f"settling time {settle_s} s; give 0 … 10 s")
    options = options or SimOptions()
    sim = sim if sim is not None else build_sim_model(robot, options)
    if law is not None and len(law.stiffness_Nm_per_rad) != robot.n_actuated:
        raise SimulationInputError(
            f"the servo law has {len(law.stiffness_Nm_per_rad)} joint(s), {robot.name} has "
            f"{robot.n_actuated}; give one servo per joint"
        )
    if law is None:
        law = robot_servo_law(robot, servo)
    roll, pitch = base_roll_pitch(trajectory.q)
    return EngineInput(
        sim=sim,
        law=law,
        q0=trajectory.q[0].copy(),
        q_cmd_rad=q_cmd,
        dt_cmd_s=trajectory.dt,
        settle_s=settle_s,
        root_height_planned_m=_root_height_above_soles(robot, trajectory),
        roll_planned_rad=roll,
        pitch_planned_rad=pitch,
        linear_hold=options.command_hold == "linear",
        balance=None
        if balance is None
        else balance_feedback(robot, trajectory, balance, roll, pitch),
    )


def _root_height_above_soles(robot: RobotModel, trajectory: Trajectory) -> np.ndarray:
    """Planned root height [m] above the lower sole, shape (T,) (the plan's floor may not be
    at z = 0 for an imported motion)."""
    model, data = robot.model, robot.model.createData()
    frames = [robot.link_frame_ids[foot.link] for foot in robot.feet]
    out = np.empty(trajectory.n_samples)
    for k, q in enumerate(trajectory.q):
        pin.framesForwardKinematics(model, data, q)
        lowest = min(
            float(
                (data.oMf[f].rotation @ foot.sole_corners_m.T)[2].min() + data.oMf[f].translation[2]
            )
            for f, foot in zip(frames, robot.feet, strict=True)
        )
        out[k] = q[2] - lowest
    return out


def planned_sole_centres(robot: RobotModel, trajectory: Trajectory) -> np.ndarray:
    """The plan's (left, right) sole centres in the world [m], shape (T, 2, 3): the mean of
    each sole's corners (where the simulation's sole-centre sites are)."""
    model, data = robot.model, robot.model.createData()
    feet = sorted(robot.feet, key=lambda foot: foot.side != "left")
    frames = [robot.link_frame_ids[foot.link] for foot in feet]
    centres = [foot.sole_corners_m.mean(axis=0) for foot in feet]
    out = np.empty((trajectory.n_samples, 2, 3))
    for k, q in enumerate(trajectory.q):
        pin.framesForwardKinematics(model, data, q)
        for i, (frame, centre) in enumerate(zip(frames, centres, strict=True)):
            out[k, i] = data.oMf[frame].act(centre)
    return out


def finish(
    robot: RobotModel, trajectory: Trajectory, inp: EngineInput, run: EngineRun, label: str
) -> SimulationResult:
    """The typed result of a run: errors against the plan, verdict, speed."""
    q_plan = joint_angles(robot, trajectory.q)
    done = run.n_simulated
    error = run.q_joints_rad[:done] - q_plan[:done]
    weight_N = robot.mass_kg * GRAVITY_MPS2
    contact = np.linalg.norm(run.contact_force_N, axis=2) > CONTACT_LOAD_FRACTION * weight_N
    slips = slip_m(run.sole_position_m, contact)
    fell = run.fall_index >= 0
    outcome = judge(
        trajectory.t,
        trajectory.contacts,
        run.contact_force_N,
        weight_N,
        slips,
        run.sole_position_m[:, :, :2],
        planned_sole_centres(robot, trajectory)[:, :, :2],
        run.root_position_m[:, :2],
        trajectory.q[:, :2],
        run.fall_index,
        run.fall_reason,
        aid="" if inp.balance is None else f"with {BALANCE_LABEL}",
        floor_index=run.floor_link_index,
        floor_link=run.floor_link,
    )
    simulated_s = (done - 1) * trajectory.dt + inp.settle_s
    return SimulationResult(
        label=label,
        robot_name=robot.name,
        joint_names=robot.joint_names,
        t=trajectory.t.copy(),
        q=run.q,
        v=run.v,
        q_cmd_rad=inp.q_cmd_rad
        if run.balance_offsets_rad is None
        else inp.q_cmd_rad + run.balance_offsets_rad,
        q_joints_rad=run.q_joints_rad,
        tau_Nm=run.tau_Nm,
        roll_rad=run.roll_rad,
        pitch_rad=run.pitch_rad,
        roll_planned_rad=inp.roll_planned_rad,
        pitch_planned_rad=inp.pitch_planned_rad,
        contact_force_N=run.contact_force_N,
        sole_position_m=run.sole_position_m,
        slip_m=slips,
        root_position_m=run.root_position_m,
        outcome=outcome,
        fell=fell,
        fall_time_s=float(trajectory.t[run.fall_index]) if fell else None,
        fall_reason=run.fall_reason,
        simulated_until_s=float(trajectory.t[done - 1]),
        rms_joint_error_deg=math.degrees(float(np.sqrt(np.mean(error**2)))),
        wall_time_s=run.wall_time_s,
        real_time_factor=simulated_s / max(run.wall_time_s, 1e-9),
        notes=inp.sim.notes + inp.law.notes,
        energy=run.energy,
        balance_feedback=None if inp.balance is None else inp.balance.gains,
        balance_offsets_rad=run.balance_offsets_rad,
    )


def simulate(
    robot: RobotModel,
    trajectory: Trajectory,
    q_cmd_rad: np.ndarray,
    servo: ServoModel,
    options: SimOptions | None = None,
    progress: Callable[[float], None] | None = None,
    label: str = "simulated",
) -> SimulationResult:
    """The motion's first pose settled on the floor, then q_cmd (T, n) [rad] sent to the
    servos at the motion's sample rate. Raises SimulationInputError / SimulationDiverged."""
    inp = prepare(robot, trajectory, q_cmd_rad, servo, options)
    return finish(robot, trajectory, inp, run_engine(inp, progress), label)


def simulate_commands(
    robot: RobotModel,
    trajectory: Trajectory,
    commands: dict[str, np.ndarray],
    servo: ServoModel,
    options: SimOptions | None = None,
    parallel: bool | None = None,
    progress: Callable[[float], None] | None = None,
    law: ServoLaw | None = None,
    balance: BalanceGains | None = None,
) -> dict[str, SimulationResult]:
    """Several command sequences (label → q_cmd (T, n) [rad]) on one robot and motion. With
    `parallel` each runs in a spawned process; the results are the same either way. A fresh
    process pays ~0.5 s of imports (numpy, mujoco), so the default runs in parallel only
    when there are two cores and the runs are long (`PARALLEL_MIN_SIMULATED_S` in all).
    `progress(fraction of all runs)` is called as they go (in parallel: when each ends);
    raising from it stops a sequential run. `law` replaces the virtual servos' (servo parts);
    `balance`: each run with the balance feedback at these gains (None: off)."""
    job = simulation_job(robot, trajectory, commands, servo, options, law, balance)
    inputs = job.inputs
    if parallel is None:
        simulated_s = len(inputs) * (trajectory.duration + SETTLE_S)
        parallel = (
            len(inputs) > 1
            and (os.cpu_count() or 1) >= 2
            and simulated_s >= PARALLEL_MIN_SIMULATED_S
        )
    if parallel:
        context = multiprocessing.get_context("spawn")
        with ProcessPoolExecutor(
            min(len(inputs), 4), mp_context=context, initializer=die_with_parent
        ) as pool:
            runs = []
            for run in pool.map(run_engine, inputs):
                runs.append(run)
                if progress is not None:
                    progress(len(runs) / len(inputs))
    else:
        runs = [
            run_engine(inp, None if progress is None else _scaled(progress, i, len(inputs)))
            for i, inp in enumerate(inputs)
        ]
    return finish_job(robot, trajectory, job, tuple(runs))


def _scaled(progress: Callable[[float], None], i: int, n: int) -> Callable[[float], None]:
    """Progress of run i of n as a fraction of all n."""
    return lambda fraction: progress((i + fraction) / n)


def simulate_plan_and_compensated(
    robot: RobotModel,
    trajectory: Trajectory,
    tau_Nm: np.ndarray,
    params: CompensationParams,
    servo: ServoModel,
    options: SimOptions | None = None,
    parallel: bool | None = None,
) -> tuple[SimulationResult, SimulationResult]:
    """(without, with compensation): q_cmd = q_plan, and q_cmd = compensated_command(q_plan,
    τ, params) (eq 7, eq 23), side by side (`simulate_commands`)."""
    q_plan = joint_angles(robot, trajectory.q)
    q_comp = compensated_command(
        q_plan, np.asarray(tau_Nm, float), params.for_joints(robot.joint_names)
    )
    labels = ("without compensation", "with compensation")
    results = simulate_commands(
        robot,
        trajectory,
        dict(zip(labels, (q_plan, q_comp), strict=True)),
        servo,
        options,
        parallel,
    )
    return results[labels[0]], results[labels[1]]


UNAIDED = " (without balance feedback)"
"""The label suffix of a run's twin without the balance feedback (`simulation_job`)."""


def simulation_job(
    robot: RobotModel,
    trajectory: Trajectory,
    commands: dict[str, np.ndarray],
    servo: ServoModel,
    options: SimOptions | None = None,
    law: ServoLaw | None = None,
    balance: BalanceGains | None = None,
    unaided: bool = False,
) -> SimulationJob:
    """Checked, picklable runs (raises SimulationInputError in the caller, not the worker);
    `law` replaces the virtual servos' (servo parts: `part_law.law_with_parts`); `balance`:
    the balance feedback's gains (None: off); `unaided` with `balance`: each run also without
    the feedback, labelled `label + UNAIDED` (the verdicts side by side, one click)."""
    from app.core.simulation.mjcf import build_sim_model

    sim = build_sim_model(robot, options)
    runs = [(label, balance) for label in commands]
    if unaided and balance is not None:
        runs += [(label + UNAIDED, None) for label in commands]
    inputs = tuple(
        prepare(
            robot, trajectory, commands[label.removesuffix(UNAIDED)], servo, options, sim=sim,
            law=law, balance=gains,
        )
        for label, gains in runs
    )  # fmt: skip
    return SimulationJob(tuple(label for label, _gains in runs), inputs)


def finish_job(
    robot: RobotModel,
    trajectory: Trajectory,
    job: SimulationJob,
    runs: tuple[EngineRun, ...],
) -> dict[str, SimulationResult]:
    """The typed results of a job's runs, by label."""
    return {
        label: finish(robot, trajectory, inp, run, label)
        for label, inp, run in zip(job.labels, job.inputs, runs, strict=True)
    }
