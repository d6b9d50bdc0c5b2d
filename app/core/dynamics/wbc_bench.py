"""Speed of the torque feed-forward, for `biped-studio bench`.

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

import dataclasses
import time
from pathlib import Path

import numpy as np

from app.core.dynamics.wbc import torque_feedforward
from app.core.motions.library import run_motion
from app.core.motions.trajectory import Trajectory
from app.core.robot.loading import load_robot

SAMPLE_TARGET_MS = 0.25
TEN_SECONDS_TARGET_S = 0.25
SCALING_TARGET = 0.7
"""Speed-up over one worker, per core, on all cores (issue 12)."""


def _run(robot_source: str | Path, motion: str) -> dict:
    robot = load_robot(robot_source)
    traj = run_motion(robot, motion, dt=0.01).trajectory
    begin, cpu = time.perf_counter(), time.process_time()
    ff = torque_feedforward(robot, traj)
    seconds, cpu_s = time.perf_counter() - begin, time.process_time() - cpu
    begin = time.perf_counter()
    full = torque_feedforward(robot, traj, solver="proxqp")
    full_s = time.perf_counter() - begin
    begin = time.perf_counter()
    torque_feedforward(robot, traj, solver="osqp")
    osqp_s = time.perf_counter() - begin
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
        "cpu_s": cpu_s,
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
                    begin = time.perf_counter()
                    torque_feedforward(robot, traj, pool=pool)
                    wall = time.perf_counter() - begin
                    seconds[label, n] = min(seconds.get((label, n), wall), wall)
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


def repeated(trajectory: Trajectory, times: int) -> Trajectory:
    """A motion played `times` over back to back (a long motion for the pool's bench)."""
    n = trajectory.n_samples * times
    return dataclasses.replace(
        trajectory,
        name=f"{trajectory.name} ×{times}",
        t=np.arange(n) * trajectory.dt,
        q=np.tile(trajectory.q, (times, 1)),
        v=np.tile(trajectory.v, (times, 1)),
        a=np.tile(trajectory.a, (times, 1)),
        contacts=np.tile(trajectory.contacts, (times, 1)),
    )
