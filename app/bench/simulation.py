"""Bench entries of the simulation (MuJoCo).

- simulate: servo_biped's one-leg squats on MuJoCo with the default virtual servos (≥ 10× real
  time), Roban S14's (≥ 5×, rigid servos) (issue 9); the same-run baseline is MuJoCo alone
  stepping the same model for the same number of steps (no servo law, no recording), so a slow
  machine shows in both numbers and the step loop's own overhead is their difference.
- simulate_parts: the same squats on MX-106 servo parts (BAM motor law, energy) against the
  ideal servo in the same run: ratio ≤ 1.5 (issue 27).
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
from app.core.simulation.engine import run_engine
from app.core.simulation.files import default_servos
from app.core.simulation.part_bench import TARGET_RATIO as PART_LAW_TARGET_RATIO
from app.core.simulation.part_bench import bench_part_law
from app.core.simulation.run import finish, prepare, simulate_commands
from app.studio import Studio
from panels.quiet import set_value

TARGET_RTF = {"servo_biped": 10.0, "roban_s14": 5.0}
"""Real-time factor targets of the simulate entry."""
SIMULATE_CLICK_TARGET_S = 2.0


@bench_entry("simulate")
def _entry_simulate(ctx: BenchContext) -> tuple[dict, list[Figure]]:
    sim = bench_simulation(str(ctx.roban) if ctx.roban else None)
    figures = []
    for key, target in TARGET_RTF.items():
        if f"{key}_wall_s" in sim:
            rtf = sim[f"{key}_real_time_factor"]
            figures.append(
                Figure(
                    f"simulate {key} one-leg squats ({sim[f'{key}_motion_s']:.1f} s)",
                    float(sim[f"{key}_wall_s"]),
                    "s",
                    f"≥ {target:.0f}× real time",
                    rtf >= target,
                    float(sim[f"{key}_physics_only_s"]),
                    "bare MuJoCo stepping the same model the same steps",
                    f"{rtf:.0f}× real time",
                )
            )
    return sim, figures


@bench_entry("simulate_parts")
def _entry_simulate_parts(ctx: BenchContext) -> tuple[dict, list[Figure]]:
    row = bench_part_law()
    return row, [
        Figure(
            f"simulate on servo parts, one-leg squats ({row['motion_s']:.1f} s)",
            float(row["part_wall_s"]),
            "s",
            f"≤ {PART_LAW_TARGET_RATIO:g}× the ideal servo's",
            bool(row["target_met"]),
            float(row["ideal_wall_s"]),
            "the ideal servo's law, same run, same motion",
            f"{row['ratio']:.2f}×",
        )
    ]


@bench_entry("simulate_click")
def _entry_simulate_click(ctx: BenchContext) -> tuple[dict, list[Figure]]:
    row = _bench_simulate_click(ctx.studio)
    return row, [
        ctx.beside_reference(
            f"Simulate click → verdict, ghosts, plots (servo_biped, {row['motion_s']:.1f} s)",
            row["seconds"],
            "s",
            f"≤ {SIMULATE_CLICK_TARGET_S:.0f} s",
            row["seconds"] <= SIMULATE_CLICK_TARGET_S,
        )
    ]


def _bench_simulate_click(studio: Studio) -> dict:
    """The Simulate button on servo_biped's one-leg squats, torques computed and the worker
    started: from the click to the verdict, ghosts and plots shown."""
    motion_with_torques(studio, "servo_biped", "one_leg_squats")
    session, panel = studio.simulation, studio.compensation.panel
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
    assert studio.state.trajectory is not None
    return {
        "motion_s": studio.state.trajectory.duration,
        "seconds": seconds,
        "first_click_s": first_s,
    }


def _physics_only_s(inp, n_steps: int) -> float:
    import mujoco

    m = mujoco.MjModel.from_xml_string(inp.sim.xml)
    d = mujoco.MjData(m)
    with stopwatch() as lap:
        for _ in range(n_steps):
            mujoco.mj_step(m, d)
    return lap.wall_s


def _time_one(
    key: str, robot: RobotModel, traj: Trajectory, servo: ServoModel
) -> dict[str, float | bool]:
    inp = prepare(robot, traj, joint_angles(robot, traj.q), servo)
    result = finish(robot, traj, inp, run_engine(inp), "bench")
    steps = round((traj.duration + inp.settle_s) / 0.001)
    return {
        f"{key}_motion_s": traj.duration,
        f"{key}_wall_s": result.wall_time_s,
        f"{key}_real_time_factor": result.real_time_factor,
        f"{key}_physics_only_s": _physics_only_s(inp, steps),
        f"{key}_target_met": result.real_time_factor >= TARGET_RTF[key],
        f"{key}_fell": result.fell,
    }


def bench_simulation(roban_urdf: str | Path | None = None) -> dict[str, float | bool]:
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
