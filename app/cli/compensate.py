"""`compensate` and `calibrate`: servo commands q + k·τ (+ φ·sign), and k from measurements."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from app.cli.common import (
    add_coefficients_arguments,
    add_motion_command,
    add_output_arguments,
    add_torques_argument,
    coefficients_from_args,
    motion_inputs,
    output_target,
    print_report,
    written,
)
from app.core.atomic_write import write_atomically
from app.core.errors import StudioError

PRESET_CHOICES = ("uniform", "table3", "table2")
"""Keys of app.core.servo.presets.PRESETS offered here (Table 3 + φ is --clearance)."""


def add_parser(sub) -> None:
    """The `compensate` and `calibrate` subcommands (servo spring/clearance compensation)."""
    compensate = add_motion_command(sub, "compensate")
    add_torques_argument(compensate, "a project's torques")
    add_coefficients_arguments(
        compensate,
        PRESET_CHOICES,
        "a preset: uniform k (Table 2's identifiable servos), the paper's Table 3 "
        "(servos 2, 3, 8, 9) or Table 2 (all 12)",
        toml_flag="--coeffs",
    )
    add_output_arguments(compensate, "command CSV to write")
    calibrate = sub.add_parser("calibrate")
    calibrate.add_argument(
        "measured", type=Path, help="CSV with header frame,joint,q_cmd_deg,q_meas_deg,tau_Nm"
    )
    calibrate.add_argument(
        "--min-tau", type=float, default=None, help="smallest useful max |τ| [N·m] (0.05)"
    )
    calibrate.add_argument(
        "--resolution-deg", type=float, default=None, help="encoder step [°] (0.078125)"
    )
    add_output_arguments(calibrate, "write the identifiable k as a k.toml")


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from app.core.servo.commands import servo_commands, torques_of_motion
    from app.core.servo.files import read_torque_csv, write_command_csv

    inputs = motion_inputs(args)
    robot, traj = inputs.robot, inputs.trajectory
    if args.tau is not None:
        torques = read_torque_csv(args.tau, robot.joint_names)
        tau, status = torques_of_motion(traj, torques, str(args.tau)), torques.status
    elif inputs.feedforward is not None:
        tau, status = inputs.feedforward.tau_Nm, inputs.feedforward.status
    else:
        raise StudioError(
            "give --tau (biped-studio feedforward --out), or a project with computed torques"
        )
    if args.preset is None and args.coeffs is None and inputs.compensation is not None:
        params = inputs.compensation
    else:
        params = coefficients_from_args(robot, args.preset, args.clearance, args.coeffs)
    commands = servo_commands(robot, traj, tau, params, status)
    q_plan, q_cmd, warnings = commands.q_plan_rad, commands.q_cmd_rad, list(commands.warnings)
    if args.out is not None:
        write_command_csv(
            args.out, traj.t, robot.joint_names, q_cmd, commands.lower_rad, commands.upper_rad
        )
    correction = np.degrees(np.abs(q_cmd - q_plan)).max(axis=0)
    joints = [
        {
            "joint": name,
            "k_deg_per_Nm": float(params.k_deg_per_Nm[i]),
            "phi_deg": float(params.phi_deg[i]),
            "max_correction_deg": float(correction[i]),
        }
        for i, name in enumerate(robot.joint_names)
        if params.enabled[i]
    ]
    if args.json:
        return print_report(
            {
                "robot": robot.name,
                "n_samples": traj.n_samples,
                "clearance_sign": params.clearance_sign,
                "compensated": joints,
                "notes": list(params.notes),
                "warnings": warnings,
                "out": written(args.out),
            }
        )
    target = output_target(args.out)
    print(
        f"{len(joints)} of {robot.n_actuated} joints compensated, {traj.n_samples} samples{target}"
    )
    for row in joints:
        print(
            f"  {row['joint']:20s} k {row['k_deg_per_Nm']:9.3f} °/(N·m)  φ {row['phi_deg']:4.1f}°  "
            f"max correction {row['max_correction_deg']:7.2f}°"
        )
    for note in params.notes:
        print(f"note: {note}")
    for line in warnings:
        print(f"warning: {line}", file=sys.stderr)
    return 0


def run_calibrate(args: argparse.Namespace) -> int:
    import numpy as np

    from app.core.servo import calibration
    from app.core.servo.compensation import CompensationParams

    options = {}
    for option, key, value in (
        ("--min-tau", "min_abs_tau_Nm", args.min_tau),
        ("--resolution-deg", "resolution_deg", args.resolution_deg),
    ):
        if value is not None:
            if not value >= 0.0:
                raise StudioError(f"{option} must be a number ≥ 0, got {value}")
            options[key] = value
    measured = calibration.read_measured_csv(args.measured)
    results = calibration.calibrate(measured, **options)
    if args.out is not None:
        names = tuple(c.joint for c in results)
        params = CompensationParams(
            names,
            np.array([c.k_deg_per_Nm if c.identifiable else 0.0 for c in results]),
            np.zeros(len(results)),
            np.array([c.identifiable for c in results]),
            notes=(f"calibrated from {args.measured}; unidentifiable joints disabled",),
        )
        text = params.to_toml()

        def write(file) -> None:
            file.write(text)

        write_atomically(args.out, write)
    if args.json:
        print(json.dumps([c.to_json() for c in results], indent=2))
        return 0
    for c in results:
        se = "   —   " if np.isnan(c.se_deg_per_Nm) else f"{c.se_deg_per_Nm:7.3g}"
        verdict = "identifiable" if c.identifiable else "NOT identifiable"
        reason = f": {c.reason}" if c.reason else ""
        print(
            f"{c.joint:20s} k {c.k_deg_per_Nm:10.4g} ± {se} °/(N·m)  {c.n_frames:4d} frame(s)  "
            f"{verdict}{reason}"
        )
    return 0
