"""Bench entry of the dynamics: the torque feed-forward (whole-body QP).

- per sample: wall time of one sample's QP (kinematics, the reduced QP in closed form or by
  DAQP), median and p95 over a motion, beside the same for the previous formulation (the full
  QP by ProxQP, warm-started) in the same run; target median ≤ 0.25 ms, on servo_biped
  (one-leg squats) and Roban S14 (CoM shift, when found);
- 10 s of motion: torque_feedforward on the servo_biped squats sampled at 100 Hz, everything
  included (QP set-up, certification), scaled to 10 s of motion, beside the same with the
  full QP by ProxQP and by OSQP; target ≤ 0.25 s on one core;
- over a pool of worker processes, every core against one (`bench_parallel`): speed-up
  ≥ 0.7 × cores.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from app.bench.registry import BenchContext, bench_entry
from app.bench.report import Figure
from app.bench.timing import PROCESS_CPU, stopwatch
from app.core.dynamics.wbc import torque_feedforward
from app.core.motions.library import run_motion
from app.core.motions.trajectory import repeated
from app.core.robot.loading import load_robot

SAMPLE_TARGET_MS = 0.25
TEN_SECONDS_TARGET_S = 0.25
SCALING_TARGET = 0.7
"""Speed-up over one worker, per core, on all cores (issue 12)."""


@bench_entry("feedforward")
def _entry_feedforward(ctx: BenchContext) -> tuple[dict, list[Figure]]:
    ff = bench_feedforward(ctx.roban)
    figures = []
    for key in ("servo_biped", "roban_s14"):
        row = ff.get(key)
        if row:
            figures.append(
                Figure.at_most(
                    f"whole-body QP per sample, {key} {row['motion']} (median)",
                    row["qp_median_ms"],
                    "ms",
                    ff["sample_target_ms"],
                    row["full_qp_median_ms"],
                    "the previous full QP (ProxQP, warm-started), median",
                    f"solve alone {row['solver_median_ms']:.3f} ms",
                    stat="median",
                )
            )
    row = ff["servo_biped"]
    figures.append(
        Figure.at_most(
            "torque feed-forward of 10 s at 100 Hz, servo_biped, one core",
            row["per_10s_s"],
            "s",
            ff["ten_seconds_target_s"],
            row["full_qp_per_10s_s"],
            "the same with the previous full QP (ProxQP)",
            f"OSQP on the full QP {row['osqp_per_10s_s']:.2f} s",
        )
    )
    par = ff["parallel"]
    figures.append(
        Figure(
            f"torque feed-forward of 10 s, servo_biped, {par['cores']} worker processes",
            par["all_cores_per_10s_s"],
            "s",
            f"speed-up ≥ {par['scaling_target']:.1f}× one worker",
            par["scaling_ok"],
            par["one_worker_per_10s_s"],
            "the same pool code with one worker",
            f"speed-up {par['scaling']:.2f}×; on {par['long_motion_s']:.0f} s of motion "
            f"{par['long_scaling']:.2f}× ({par['long_all_cores_per_10s_s']:.2f} s per 10 s) "
            f"(busy loops on the same pools: {par['busy_loop_scaling']:.2f}×)",
        )
    )
    return ff, figures


def _run(robot_source: str | Path, motion: str) -> dict:
    robot = load_robot(robot_source)
    traj = run_motion(robot, motion, dt=0.01).trajectory
    with stopwatch(PROCESS_CPU) as reduced:
        ff = torque_feedforward(robot, traj)
    with stopwatch() as proxqp:
        full = torque_feedforward(robot, traj, solver="proxqp")
    with stopwatch() as osqp:
        torque_feedforward(robot, traj, solver="osqp")
    seconds, full_s, osqp_s = reduced.wall_s, proxqp.wall_s, osqp.wall_s
    ms, full_ms = ff.qp_time_s * 1e3, full.qp_time_s * 1e3
    return {
        "robot": robot.name,
        "motion": motion,
        "samples": traj.n_samples,
        "duration_s": traj.duration,
        "qp_median_ms": float(np.median(ms)),
        "qp_p95_ms": float(np.percentile(ms, 95)),
        "full_qp_median_ms": float(np.median(full_ms)),
        "full_qp_p95_ms": float(np.percentile(full_ms, 95)),
        "solver_median_ms": float(np.median(ff.solver_time_s * 1e3))
        if ff.solver_time_s is not None
        else float("nan"),
        "seconds": seconds,
        "cpu_s": reduced.cpu_s,
        "per_10s_s": seconds * 10.0 / traj.duration,
        "full_qp_per_10s_s": full_s * 10.0 / traj.duration,
        "osqp_per_10s_s": osqp_s * 10.0 / traj.duration,
        "not_solved": len(ff.infeasible_samples),
    }


def bench_feedforward(roban_urdf: Path | None = None) -> dict:
    """{"servo_biped": row, "roban_s14": row or None, "ten_seconds_s": …, targets, ok flags}."""
    servo = _run("servo_biped", "one_leg_squats")
    roban = _run(roban_urdf, "com_shift") if roban_urdf and roban_urdf.exists() else None
    rows = [row for row in (servo, roban) if row is not None]
    return {
        "parallel": bench_parallel(),
        "servo_biped": servo,
        "roban_s14": roban,
        "ten_seconds_s": servo["per_10s_s"],
        "sample_target_ms": SAMPLE_TARGET_MS,
        "ten_seconds_target_s": TEN_SECONDS_TARGET_S,
        "sample_ok": all(row["qp_median_ms"] <= SAMPLE_TARGET_MS for row in rows),
        "ten_seconds_ok": servo["per_10s_s"] <= TEN_SECONDS_TARGET_S,
    }


def bench_parallel(workers: int | None = None, repeats: int = 7) -> dict:
    """servo_biped's squats (10 s) and the same repeated six times (60 s: 10 s is ~0.1 s of
    CPU since the reduced QP, too short to split usefully) through a warm pool of one worker,
    then of every core (each run once untimed first, so both pools have built their QPs; then
    `repeats` alternated runs, the fastest kept): wall times and the scalings, beside the
    scaling of plain busy loops over the same pools (what the machine gives these processes
    at that moment: on a shared machine the ceiling is below the core count)."""
    import os

    from app.core.dynamics.parallel import FeedForwardPool

    robot = load_robot("servo_biped")
    short = run_motion(robot, "one_leg_squats", dt=0.01).trajectory
    long = repeated(short, 6)
    cores = workers or os.cpu_count() or 1
    with FeedForwardPool(1) as one, FeedForwardPool(cores) as every:
        pools = {1: one, cores: every}
        seconds: dict[tuple[str, int], float] = {}
        for label, traj in (("short", short), ("long", long)):
            for pool in pools.values():
                torque_feedforward(robot, traj, pool=pool)
            for _ in range(repeats):
                for n, pool in pools.items():
                    with stopwatch() as lap:
                        torque_feedforward(robot, traj, pool=pool)
                    seconds[label, n] = min(seconds.get((label, n), lap.wall_s), lap.wall_s)
        busy = {n: pool.busy_wall_s(2 * cores, 0.05) for n, pool in pools.items()}
    scaling = seconds["short", 1] / seconds["short", cores]
    return {
        "busy_loop_scaling": busy[1] / busy[cores],
        "cores": cores,
        "one_worker_per_10s_s": seconds["short", 1] * 10.0 / short.duration,
        "all_cores_per_10s_s": seconds["short", cores] * 10.0 / short.duration,
        "scaling": scaling,
        "long_motion_s": long.duration,
        "long_one_worker_per_10s_s": seconds["long", 1] * 10.0 / long.duration,
        "long_all_cores_per_10s_s": seconds["long", cores] * 10.0 / long.duration,
        "long_scaling": seconds["long", 1] / seconds["long", cores],
        "scaling_target": SCALING_TARGET * cores,
        "scaling_ok": scaling >= SCALING_TARGET * cores,
    }
