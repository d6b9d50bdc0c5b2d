"""Speed of the torque feed-forward, for `biped-studio bench`.

- per sample: wall time of one sample's QP (kinematics, matrix values, OSQP update and
  solve), median and p95 over a motion; target median ≤ 0.5 ms, on servo_biped (one-leg
  squats) and Roban S14 (CoM shift, when its URDF is found);
- 10 s of motion: torque_feedforward on the servo_biped squats sampled at 100 Hz, everything
  included (QP set-up, certification), scaled to 10 s of motion; target ≤ 0.5 s.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from app.core.dynamics.wbc import torque_feedforward
from app.core.motions.library import run_motion
from app.core.robot.loading import load_robot

SAMPLE_TARGET_MS = 0.5
TEN_SECONDS_TARGET_S = 0.5


def _run(robot_source: str | Path, motion: str) -> dict:
    robot = load_robot(robot_source)
    traj = run_motion(robot, motion, dt=0.01).trajectory
    begin = time.perf_counter()
    ff = torque_feedforward(robot, traj)
    seconds = time.perf_counter() - begin
    ms = ff.qp_time_s * 1e3
    return {
        "robot": robot.name,
        "motion": motion,
        "samples": traj.n_samples,
        "duration_s": traj.duration,
        "qp_median_ms": float(np.median(ms)),
        "qp_p95_ms": float(np.percentile(ms, 95)),
        "solver_median_ms": float(np.median(ff.solver_time_s * 1e3))
        if ff.solver_time_s is not None
        else float("nan"),
        "seconds": seconds,
        "per_10s_s": seconds * 10.0 / traj.duration,
        "not_solved": len(ff.infeasible_samples),
    }


def bench_feedforward(roban_urdf: Path | None = None) -> dict:
    """{"servo_biped": row, "roban_s14": row or None, "ten_seconds_s": …, targets, ok flags}."""
    servo = _run("servo_biped", "one_leg_squats")
    roban = _run(roban_urdf, "com_shift") if roban_urdf and roban_urdf.exists() else None
    rows = [row for row in (servo, roban) if row is not None]
    return {
        "servo_biped": servo,
        "roban_s14": roban,
        "ten_seconds_s": servo["per_10s_s"],
        "sample_target_ms": SAMPLE_TARGET_MS,
        "ten_seconds_target_s": TEN_SECONDS_TARGET_S,
        "sample_ok": all(row["qp_median_ms"] <= SAMPLE_TARGET_MS for row in rows),
        "ten_seconds_ok": servo["per_10s_s"] <= TEN_SECONDS_TARGET_S,
    }
