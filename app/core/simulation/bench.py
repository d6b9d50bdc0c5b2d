"""Speed of the simulation, for `biped-studio bench`: real-time factors against the targets.

Targets (issue 9): a 10 s motion at 100 Hz on servo_biped simulated at ≥ 10× real time,
Roban S14 at ≥ 5×. The same-run baseline is MuJoCo alone stepping the same model for the same
number of steps (no servo law, no recording), so a slow machine shows in both numbers and the
step loop's own overhead is their difference.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from app.core.motions.trajectory import Trajectory
from app.core.robot.model import RobotModel
from app.core.servo.model import ServoModel, joint_angles
from app.core.simulation.engine import run_engine
from app.core.simulation.files import default_servos
from app.core.simulation.run import finish, prepare, simulate_commands

TARGET_RTF = {"servo_biped": 10.0, "roban_s14": 5.0}


def _physics_only_s(inp, n_steps: int) -> float:
    import mujoco

    m = mujoco.MjModel.from_xml_string(inp.sim.xml)
    d = mujoco.MjData(m)
    begin = time.perf_counter()
    for _ in range(n_steps):
        mujoco.mj_step(m, d)
    return time.perf_counter() - begin


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
        begin = time.perf_counter()
        simulate_commands(robot, traj, pair, default_servos(robot), parallel=parallel)
        out[label] = time.perf_counter() - begin
    if roban_urdf is not None:
        roban = load_robot(roban_urdf)
        # Rigid servos: on 1.4 °/(N·m) leg servos Roban falls while settling (README), and a
        # run that stops after a fall would time 0.5 s of it.
        traj = run_motion(roban, "one_leg_squats").trajectory
        out.update(_time_one("roban_s14", roban, traj, ServoModel.rigid(roban.joint_names)))
    return out
