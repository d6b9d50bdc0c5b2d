"""Bench entry of the motions: a keyframed motion made with the IK at every sample.

- interpolate: a keyframed motion (the three one-leg squats) sampled at 100 Hz with IK at
  every sample, scaled to 10 s of motion, CPU, best of 3 runs (median beside); target ≤ 0.5 s;
  beside it the whole-body IK's own solves in the same run.
"""

from __future__ import annotations

import statistics

from app.bench.registry import BenchContext, bench_entry
from app.bench.report import Figure
from app.bench.timing import stopwatch, tallied
from app.studio import Studio

INTERPOLATE_TARGET_S = 0.5
INTERPOLATE_RUNS = 3
"""The keyframed motion is generated this many times (a fresh IK each) and the fastest run
kept, as the IK's drag figure keeps the best of its passes: one run of half a second on a
shared machine measures the machine's other work as much as the code; the median is printed
beside it."""


@bench_entry("interpolate")
def _entry_interpolate(ctx: BenchContext) -> tuple[dict, list[Figure]]:
    row = _bench_interpolate(ctx.studio)
    return row, [
        Figure.at_most(
            f"keyframed motion at 100 Hz with IK at every sample, per 10 s (CPU, best of "
            f"{row['runs']} runs)",
            row["cpu_per_10s_s"],
            "s",
            INTERPOLATE_TARGET_S,
            row["ik_cpu_per_10s_s"],
            "the whole-body IK's own solves in the same run, CPU",
            f"median of the runs {row['median_cpu_per_10s_s']:.3f} s; wall {row['per_10s_s']:.2f} s",
        )
    ]


def _bench_interpolate(studio: Studio) -> dict:
    """The one-leg squats interpolated at 100 Hz; beside it, the CPU time spent inside the
    whole-body IK's own solves during the same run (the rest is the motion code's)."""
    from app.core.motions.keyframes import interpolate
    from app.core.motions.library import MOTIONS, resolve_params
    from app.core.posing.ik import WholeBodyIK
    from app.core.posing.ready_pose import MOTION_POSTURE_WEIGHT

    studio.robots.load("servo_biped")
    robot = studio.state.robot
    assert robot is not None
    plan = MOTIONS["one_leg_squats"].build(robot, **resolve_params("one_leg_squats", {}))

    runs = []  # (CPU s, wall s, the IK's CPU s, duration s) per run
    for _ in range(INTERPOLATE_RUNS):
        ik = WholeBodyIK(robot, com_in_support=True, posture_weight=MOTION_POSTURE_WEIGHT)
        ik_laps: list[float] = []
        ik.solve = tallied(ik.solve, ik_laps)  # type: ignore[method-assign]
        with stopwatch() as lap:
            result = interpolate(robot, plan.keyframes, dt=0.01, ik=ik)
        runs.append((lap.cpu_s, lap.wall_s, sum(ik_laps), result.trajectory.duration))
    cpu_s, seconds, ik_cpu_s, duration = min(runs)
    return {
        "motion": "one_leg_squats",
        "runs": len(runs),
        "duration_s": duration,
        "seconds": seconds,
        "per_10s_s": seconds * 10.0 / duration,
        "cpu_per_10s_s": cpu_s * 10.0 / duration,
        "median_cpu_per_10s_s": statistics.median(run[0] for run in runs) * 10.0 / duration,
        "ik_cpu_per_10s_s": ik_cpu_s * 10.0 / duration,
    }
