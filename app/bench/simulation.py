"""Bench entries of the simulation (MuJoCo).

- simulate: servo_biped's one-leg squats on MuJoCo with the default virtual servos (≥ 10× real
  time), Roban S14's (≥ 5×, rigid servos) (issue 9), CPU per physics step; the same-run
  baseline is bare MuJoCo stepping the same model (with the servos' actuators) from the same
  settled start with the same set points, all in C (`mujoco.rollout`, sensors off, no
  recording, no fall verdict): the same physics and torques, so the ratio is the step loop's
  own overhead (its model's compilation, the set points, the samples' batched forward pass
  and recording, the verdicts); target ≤ 1.3× (issue 28).
- simulate_parts: the same squats on MX-106 servo parts (BAM motor law, energy) against the
  ideal servo in the same run, CPU: ratio ≤ 1.5 (issue 27). Both step a block of samples per
  call into C (`app.core.simulation.blocks`, `part_blocks`); the part's law ticking in Python
  at every tick, as it ran before, is timed in the same rounds and shown beside.
- simulate_click: the studio's Simulate click to the verdict, ghosts and plots (≤ 2 s), with the
  worker already started.
"""

from __future__ import annotations

import threading
from pathlib import Path

import numpy as np

from app.bench.registry import BenchContext, bench_entry, motion_with_torques
from app.bench.report import Figure
from app.bench.timing import stopwatch, timed_each
from app.core.motions.trajectory import Trajectory
from app.core.robot.model import RobotModel
from app.core.servo.model import ServoModel, joint_angles
from app.core.simulation.engine import EngineInput, run_engine, start
from app.core.simulation.files import default_servos
from app.core.simulation.part_bench import TARGET_RATIO as PART_LAW_TARGET_RATIO
from app.core.simulation.part_bench import bench_part_law
from app.core.simulation.run import finish, prepare, simulate_commands
from app.core.simulation.servo_law import Setpoints
from app.studio import Studio
from panels.quiet import set_value

TARGET_RTF = {"servo_biped": 10.0, "roban_s14": 5.0}
"""Real-time factor targets of the simulate entry."""
SIMULATE_CLICK_TARGET_S = 2.0
SIMULATE_BARE_RATIO = 1.3
"""A simulation step's CPU over bare MuJoCo's on the same physics (issue 28)."""


@bench_entry("simulate")
def _entry_simulate(ctx: BenchContext) -> tuple[dict, list[Figure]]:
    sim = bench_simulation(str(ctx.roban) if ctx.roban else None)
    figures = []
    for key, target in TARGET_RTF.items():
        if f"{key}_cpu_s" in sim:
            steps, rtf = float(sim[f"{key}_steps"]), float(sim[f"{key}_real_time_factor"])
            ratios = sim[f"{key}_pair_ratios"]
            value = float(sim[f"{key}_cpu_s"]) / steps * 1e6
            bare = float(sim[f"{key}_bare_cpu_s"]) / steps * 1e6
            figures.append(
                Figure(
                    f"simulate {key} one-leg squats ({sim[f'{key}_motion_s']:.1f} s), CPU per "
                    "physics step",
                    value,
                    "µs",
                    f"≤ {SIMULATE_BARE_RATIO:g}× bare MuJoCo; ≥ {target:.0f}× real time",
                    value <= SIMULATE_BARE_RATIO * bare and rtf >= target,
                    bare,
                    "bare MuJoCo (mujoco.rollout, in C) stepping the same model, start and "
                    "servo set points, CPU per step",
                    f"{rtf:.0f}× real time; {steps:.0f} steps; the pairs' ratios {ratios}",
                )
            )
    return sim, figures


@bench_entry("simulate_parts")
def _entry_simulate_parts(ctx: BenchContext) -> tuple[dict, list[Figure]]:
    row = bench_part_law()
    return row, [
        Figure(
            f"simulate on servo parts, one-leg squats ({row['motion_s']:.1f} s), CPU",
            float(row["part_cpu_s"]),
            "s",
            f"≤ {PART_LAW_TARGET_RATIO:g}× the ideal servo's",
            bool(row["target_met"]),
            float(row["ideal_cpu_s"]),
            "the ideal servo's law (in C too), same run, same motion, CPU",
            f"median of the rounds' ratios {row['ratio']:.2f}× (rounds {row['round_ratios']}); "
            f"the part's law ticking in Python as before: {row['part_per_tick_cpu_s']:.3g} s, "
            f"{row['per_tick_ratio']:.2f}× the ideal servo's, "
            f"{row['speedup_over_per_tick']:.2f}× the blocks' time",
        )
    ]


@bench_entry("simulate_click")
def _entry_simulate_click(ctx: BenchContext) -> tuple[dict, list[Figure]]:
    row = _bench_simulate_click(ctx.studio)
    return row, [
        Figure.at_most(
            f"Simulate click → verdict, ghosts, plots (servo_biped, {row['motion_s']:.1f} s)",
            row["seconds"],
            "s",
            SIMULATE_CLICK_TARGET_S,
            row["core_s"],
            "the core's simulation of the same motion alone (no worker, verdict, ghosts or plots)",
        )
    ]


def _bench_simulate_click(studio: Studio) -> dict:
    """The Simulate button on servo_biped's one-leg squats, torques computed and the worker
    started: from the click to the verdict, ghosts and plots shown."""
    motion_with_torques(studio, "servo_biped", "one_leg_squats")
    session, panel = studio.servo_rooms.simulation, studio.servo_rooms.compensation.panel
    done = threading.Event()
    disconnect = session.runner.finished.connect(lambda _simulation: done.set())

    def click(_run: int) -> None:
        done.clear()
        session.simulate()
        done.wait()

    (first_s,) = timed_each(click, range(1))  # the worker's first simulation
    set_value(panel.k, float(panel.k.value) + 0.1)  # the simulation is now stale
    (seconds,) = timed_each(click, range(1))
    disconnect()
    robot, trajectory = studio.state.robot, studio.state.trajectory
    assert robot is not None and trajectory is not None
    inp = prepare(robot, trajectory, joint_angles(robot, trajectory.q), default_servos(robot))
    (core_s,) = timed_each(lambda _: run_engine(inp), range(1))
    return {
        "motion_s": trajectory.duration,
        "seconds": seconds,
        "first_click_s": first_s,
        "core_s": core_s,
    }


def bare_mujoco_cpu_s(inp: EngineInput, repeats: int = 3) -> tuple[float, int]:
    """CPU time [s] of bare MuJoCo stepping the run's model from its start with the set points
    the step loop sends (settling, then every command held or ramped), all the steps in one
    `mujoco.rollout` call (C, no Python per step); best of `repeats`; and the step count."""
    import mujoco
    from mujoco import rollout

    m, d, ctrl_joint, ticks = start(inp)
    m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_SENSOR)  # the physics alone
    commands = np.asarray(inp.q_cmd_rad, dtype=float)
    dt = float(m.opt.timestep)
    setpoints = Setpoints(inp.law, dt, commands[0])
    settle = round(inp.settle_s / dt)
    blocks = [(setpoints.hold(commands[0], settle), commands[0], settle)]
    for k in range(len(commands) - 1):
        rows = (
            setpoints.ramp(commands[k], commands[k + 1], ticks)
            if inp.linear_hold
            else setpoints.hold(commands[k], ticks)
        )
        blocks.append((rows, commands[k], ticks))
    control = np.concatenate(
        [np.tile(c, (n, 1)) if rows is None else rows for rows, c, n in blocks]
    )[:, ctrl_joint]
    kind = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.zeros(mujoco.mj_stateSize(m, kind))
    mujoco.mj_getState(m, d, state, kind)
    best = float("inf")
    for _ in range(repeats):
        with stopwatch() as lap:
            rollout.rollout(m, d, state[None], control[None])
        best = min(best, lap.cpu_s)
    return best, len(control)


def _time_one(
    key: str, robot: RobotModel, traj: Trajectory, servo: ServoModel, repeats: int = 5
) -> dict[str, float | bool | str]:
    """The studio's step loop and bare MuJoCo on the same work (CPU), in `repeats` pairs run
    back to back, so that each pair meets the same load; the pair of median ratio is
    reported (the best of each side taken apart would pair a lucky moment of one with an
    unlucky one of the other on a machine whose speed drifts)."""
    inp = prepare(robot, traj, joint_angles(robot, traj.q), servo)
    pairs = []
    for _ in range(repeats):
        with stopwatch() as lap:
            run = run_engine(inp)
        bare_s, steps = bare_mujoco_cpu_s(inp, 1)
        pairs.append((lap.cpu_s / bare_s, lap.cpu_s, bare_s))
    _, cpu, bare = sorted(pairs)[len(pairs) // 2]
    result = finish(robot, traj, inp, run, "bench")
    rtf = (traj.duration + inp.settle_s) / cpu
    return {
        f"{key}_motion_s": traj.duration,
        f"{key}_steps": steps,
        f"{key}_cpu_s": cpu,
        f"{key}_bare_cpu_s": bare,
        f"{key}_pair_ratios": ", ".join(f"{pair[0]:.2f}" for pair in sorted(pairs)),
        f"{key}_wall_s": result.wall_time_s,
        f"{key}_real_time_factor": rtf,
        f"{key}_target_met": rtf >= TARGET_RTF[key] and cpu <= SIMULATE_BARE_RATIO * bare,
        f"{key}_fell": result.fell,
    }


def bench_simulation(roban_urdf: str | Path | None = None) -> dict[str, float | bool | str]:
    """Time the simulation of servo_biped's one-leg squats (9.5 s, default servos) and, when a
    path is given, Roban S14's (rigid servos); and the two runs without/with compensation side by side (parallel when
    there are two cores) against one after the other. Motions are generated first (untimed)."""
    from app.core.motions.library import run_motion
    from app.core.robot.loading import load_robot

    robot = load_robot("servo_biped")
    traj = run_motion(robot, "one_leg_squats").trajectory
    out = _time_one("servo_biped", robot, traj, default_servos(robot))
    q_plan = joint_angles(robot, traj.q)
    lower = [joint.lower for joint in robot.joints]
    upper = [joint.upper for joint in robot.joints]
    pair = {"without": q_plan, "with": np.clip(q_plan + np.deg2rad(0.5), lower, upper)}
    for label, parallel in (("pair_parallel_wall_s", True), ("pair_sequential_wall_s", False)):
        with stopwatch() as lap:
            simulate_commands(robot, traj, pair, default_servos(robot), parallel=parallel)
        out[label] = lap.wall_s
    if roban_urdf is not None:
        roban = load_robot(roban_urdf)
        # Rigid servos: on 1.4 °/(N·m) leg servos Roban falls while settling (docs/simulation.md), and a
        # run that stops after a fall would time 0.5 s of it.
        traj = run_motion(roban, "one_leg_squats").trajectory
        out.update(_time_one("roban_s14", roban, traj, ServoModel.rigid(roban.joint_names)))
    return out
