"""Speed of the part's servo law against the ideal servo's, for `biped-studio bench`.

Target (issue 27): the part's law (BAM motor law, m1 friction, energy accounting) costs
≤ 1.5× the ideal servo's in the same run, same motion (servo_biped's one-leg squats on MX-106
parts against the default virtual servos). Best of `repeats` runs of each, interleaved, so a
busy machine slows both alike.
"""

from __future__ import annotations

import time

TARGET_RATIO = 1.5


def bench_part_law(repeats: int = 3) -> dict[str, float | bool]:
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
    best = {"ideal": float("inf"), "part": float("inf")}
    for _ in range(repeats):
        for name, inp in (("ideal", ideal), ("part", part)):
            begin = time.perf_counter()
            run_engine(inp)
            best[name] = min(best[name], time.perf_counter() - begin)
    ratio = best["part"] / best["ideal"]
    return {
        "motion_s": traj.duration,
        "ideal_wall_s": best["ideal"],
        "part_wall_s": best["part"],
        "ratio": ratio,
        "target_met": ratio <= TARGET_RATIO,
    }
