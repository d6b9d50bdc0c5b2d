"""`feedforward`: joint torques of a motion by the whole-body QP."""

from __future__ import annotations

import argparse
import sys

from app.cli.common import (
    MAX_WARNING_LINES,
    add_motion_command,
    add_output_arguments,
    motion_inputs,
    output_target,
    print_report,
    written,
)
from app.core.errors import StudioError


def add_parser(sub) -> None:
    feedforward = add_motion_command(sub, "feedforward")
    feedforward.add_argument(
        "--workers",
        type=int,
        default=1,
        help="worker processes solving chunks of samples in parallel (0: one per core, "
        "or in-process for a motion too short to gain from them)",
    )
    add_output_arguments(feedforward, "torque CSV: t [s], tau:<joint> [N·m]…, status")


def run(args: argparse.Namespace) -> int:
    import time

    import numpy as np

    inputs = motion_inputs(args)  # a bad input is refused before the QP's libraries load
    robot, traj = inputs.robot, inputs.trajectory
    if args.workers < 0:
        raise StudioError(f"--workers must be 0 (one per core) or more, got {args.workers}")
    from app.core.dynamics.parallel import worth_a_pool
    from app.core.dynamics.peaks import torque_peaks
    from app.core.dynamics.wbc import torque_feedforward
    from app.core.servo.files import write_torque_csv

    begin = time.perf_counter()
    if args.workers == 1 or (args.workers == 0 and not worth_a_pool(traj.n_samples)):
        ff = torque_feedforward(robot, traj)
    else:
        from app.core.dynamics.parallel import FeedForwardPool

        with FeedForwardPool(args.workers or None) as pool:
            ff = torque_feedforward(robot, traj, pool=pool)
    seconds = time.perf_counter() - begin
    if args.out is not None:
        write_torque_csv(args.out, ff)
    bad = [int(k) for k in ff.infeasible_samples]
    summary = torque_peaks(robot, traj, ff)
    peaks = summary.max_abs_tau_Nm  # over samples neither infeasible nor over the speed limits
    if args.json:
        return print_report(
            {
                "robot": robot.name,
                "trajectory": str(args.trajectory),
                "n_samples": traj.n_samples,
                "out": written(args.out),
                **summary.to_json(),
                "infeasible_samples": bad,
                "first_problems": [
                    {"index": k, "status": ff.status[k]} for k in bad[:MAX_WARNING_LINES]
                ],
                "solve_time_s": seconds,
                "qp_time_median_ms": float(np.median(ff.qp_time_s) * 1e3),
                "qp_time_p95_ms": float(np.percentile(ff.qp_time_s, 95) * 1e3),
                "notes": list(ff.notes),
            }
        )
    worst = int(np.argmax(peaks))
    target = output_target(args.out)
    print(
        f"feedforward {traj.name} on {robot.name}: {traj.n_samples} samples in {seconds:.2f} s, "
        f"{len(bad)} not solved, max |tau| {peaks[worst]:.3g} N·m ({ff.joint_names[worst]}), "
        f"{len(summary.flagged_samples)} flagged sample(s) left out of the peaks{target}"
    )
    for line in [*ff.notes, *(f"sample {k}: {ff.status[k]}" for k in bad)][:MAX_WARNING_LINES]:
        print(f"warning: {line}", file=sys.stderr)
    if len(ff.notes) + len(bad) > MAX_WARNING_LINES:
        print("warning: … more (--json lists every sample not solved)", file=sys.stderr)
    return 0
