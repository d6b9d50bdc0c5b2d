"""Speed of the part's servo law against the ideal servo's, for `biped-studio bench`.

Target (issue 27): the part's law (BAM motor law, m1 friction, energy accounting) costs
≤ 1.5× the ideal servo's in the same run, same motion (servo_biped's one-leg squats on MX-106
parts against the default virtual servos). Both run a block of samples per call into C
(`blocks`, `part_blocks`); the part's law as it ticked in Python before (`PartLoop` at every
tick, `servo_in_mujoco=False`) is timed beside them. CPU time of the process, in `repeats`
rounds of the three back to back, so that each round meets the same load; the ratios are the
median of the rounds' ratios (each side's best taken apart would pair a quiet moment of one
with a busy one of the other).
"""

from __future__ import annotations

import dataclasses
import statistics
import time

TARGET_RATIO = 1.5


def bench_part_law(repeats: int = 5) -> dict[str, float | bool | str]:
    from app.core.motions.library import run_motion
    from app.core.robot.loading import load_robot
    from app.core.servo.catalogue import load_catalogue
    from app.core.servo.model import joint_angles
    from app.core.servo.parts import parts_from_mapping
    from app.core.simulation.engine import run_engine
    from app.core.simulation.files import default_servos
    from app.core.simulation.part_law import part_servo_law
    from app.core.simulation.run import prepare

    robot = load_robot("servo_biped")
    traj = run_motion(robot, "one_leg_squats").trajectory
    q_plan = joint_angles(robot, traj.q)
    parts = parts_from_mapping({"servo": "mx106"}, robot.joint_names, load_catalogue(), "bench")
    ideal = prepare(robot, traj, q_plan, default_servos(robot))
    part = prepare(
        robot, traj, q_plan, parts.servo_model(), sim=ideal.sim, law=part_servo_law(parts)
    )
    runs = {
        "ideal": ideal,
        "part": part,
        "part_per_tick": dataclasses.replace(part, servo_in_mujoco=False),
    }
    cpu: dict[str, list[float]] = {name: [] for name in runs}
    for _ in range(repeats):
        for name, inp in runs.items():
            begin = time.process_time()
            run_engine(inp)
            cpu[name].append(time.process_time() - begin)
    rounds = list(zip(cpu["ideal"], cpu["part"], cpu["part_per_tick"], strict=True))
    ratios = sorted(p / i for i, p, _ in rounds)
    ratio = statistics.median(ratios)
    return {
        "motion_s": traj.duration,
        "ideal_cpu_s": statistics.median(cpu["ideal"]),
        "part_cpu_s": statistics.median(cpu["part"]),
        "part_per_tick_cpu_s": statistics.median(cpu["part_per_tick"]),
        "ratio": ratio,
        "round_ratios": ", ".join(f"{r:.2f}" for r in ratios),
        "per_tick_ratio": statistics.median(t / i for i, _, t in rounds),
        "speedup_over_per_tick": statistics.median(t / p for _, p, t in rounds),
        "target_met": ratio <= TARGET_RATIO,
    }
