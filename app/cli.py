"""biped-studio: the studio server and the headless commands.

Every command prints one line and exits non-zero on bad input (no traceback); `--json`
gives machine-readable output.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from app.config import StudioConfig
from app.core.errors import StudioError
from robots.catalogue import BUILTIN_ROBOTS, DEFAULT_ROBOT

MAX_WARNING_LINES = 12
"""`motion` prints at most this many warning lines (grouped per keyframe) on stderr."""


def main(argv: list[str] | None = None) -> int:
    parser = _parser()
    args = parser.parse_args(argv)
    command = args.command or "serve"
    try:
        if command == "serve":
            return _serve(args)
        if command == "robots":
            return _robots(args)
        if command == "check":
            return _check(args)
        if command == "motion":
            return _motion(args)
        if command == "feedforward":
            return _feedforward(args)
        if command == "compensate":
            return _compensate(args)
        if command == "calibrate":
            return _calibrate(args)
        if command == "plan":
            return _plan(args)
        if command == "bench":
            from app.bench import run_bench

            return run_bench(args)
    except StudioError as error:
        if getattr(args, "json", False):
            print(json.dumps({"ok": False, "error": str(error)}))
        print(f"biped-studio {command}: {error}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:  # output piped into `head` and the like
        sys.stderr.close()
        return 0
    parser.error(f"unknown command {command}")
    return 2


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="biped-studio", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command")
    serve = sub.add_parser("serve", help="start the studio (the default command)")
    serve.add_argument("--robot", default=DEFAULT_ROBOT, help="built-in name or URDF path")
    serve.add_argument(
        "--host", default="127.0.0.1", help="interface; 0.0.0.0 exposes the studio to the network"
    )
    serve.add_argument("--port", type=int, default=8080)
    _robot_options(serve)
    robots = sub.add_parser("robots", help="list the built-in robots")
    robots.add_argument("--json", action="store_true")
    check = sub.add_parser("check", help="load a robot and print its report")
    check.add_argument("robot", help="built-in name or URDF path")
    check.add_argument("--json", action="store_true")
    _robot_options(check)
    motion = sub.add_parser(
        "motion",
        help="make a built-in motion (CoM shift, one-leg squats, swings, steps) and write it as CSV",
    )
    motion.add_argument("name", help="motion name, or 'list' to list the motions and parameters")
    motion.add_argument("--robot", default=DEFAULT_ROBOT, help="built-in name or URDF path")
    motion.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="motion parameter (repeatable); 'auto' restores a robot-scaled default",
    )
    motion.add_argument("--dt", type=float, default=0.01, help="sample time step [s]")
    motion.add_argument("--out", type=Path, default=None, help="CSV file to write")
    motion.add_argument("--json", action="store_true")
    _robot_options(motion)
    bench = sub.add_parser("bench", help="measure the studio's speed targets")
    bench.add_argument(
        "--robot", default=None, help="URDF to time loading on (default: Roban S14 if found)"
    )
    bench.add_argument("--repeats", type=int, default=200)
    bench.add_argument("--json", action="store_true")
    _add_feedforward_command(sub)
    _add_compensation_commands(sub)
    _add_plan_command(sub)
    # Plain `biped-studio` serves the default robot.
    parser.set_defaults(
        robot=DEFAULT_ROBOT, host="127.0.0.1", port=8080, package_root=[], feet=None
    )
    return parser


def _robot_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--package-root",
        action="append",
        default=[],
        type=Path,
        help="folder holding package://NAME folders (repeatable)",
    )
    parser.add_argument(
        "--feet", default=None, help="LEFT,RIGHT foot link names, overriding detection"
    )


def _feet(value: str | None) -> tuple[str, str] | None:
    if value is None:
        return None
    names = [name.strip() for name in value.split(",")]
    if len(names) != 2 or not all(names):
        raise StudioError(f"--feet takes two link names separated by a comma, got {value!r}")
    return names[0], names[1]


def _serve(args: argparse.Namespace) -> int:
    from app.core.robot.loading import load_robot
    from app.studio import Studio

    config = StudioConfig(
        robot=args.robot,
        host=args.host,
        port=args.port,
        package_roots=tuple(args.package_root),
        feet=_feet(args.feet),
    )
    robot = load_robot(config.robot, package_roots=config.package_roots, feet=config.feet)
    if not config.is_local:
        print(
            f"warning: serving on {config.host}: anyone who can reach this machine can use the studio "
            "and read robot files it can open",
            file=sys.stderr,
        )
    studio = Studio(config, robot)
    host = "127.0.0.1" if config.host in ("0.0.0.0", "::") else config.host
    print(
        f"Biped Studio on http://{host}:{studio.server.get_port()} — {robot.name}. Ctrl+C stops it.",
        flush=True,
    )
    try:
        studio.server.sleep_forever()
    finally:
        studio.stop()
    return 0


def _robots(args: argparse.Namespace) -> int:
    from app.core.robot.loading import load_robot

    rows = []
    for name, entry in BUILTIN_ROBOTS.items():
        robot = load_robot(name)
        rows.append(
            {
                "name": name,
                "n_actuated": robot.n_actuated,
                "mass_kg": round(robot.mass_kg, 4),
                "default": name == DEFAULT_ROBOT,
                "summary": entry.summary,
            }
        )
    if args.json:
        print(json.dumps(rows, indent=2))
    else:
        for row in rows:
            mark = " (default)" if row["default"] else ""
            print(
                f"{row['name']:18s} {row['n_actuated']:3d} DOF {row['mass_kg']:8.3f} kg  {row['summary']}{mark}"
            )
    return 0


def _check(args: argparse.Namespace) -> int:
    from app.core.robot.loading import load_robot
    from app.core.robot.report import robot_report

    robot = load_robot(args.robot, package_roots=tuple(args.package_root), feet=_feet(args.feet))
    report = robot_report(robot)
    if args.json:
        print(json.dumps(report.to_json(), indent=2))
    else:
        print("\n".join(report.lines()))
    return 0


def _params(pairs: list[str]) -> dict[str, str]:
    """--param NAME=VALUE pairs as a dict (the motion checks names and values)."""
    params: dict[str, str] = {}
    for pair in pairs:
        name, sep, value = pair.partition("=")
        name, value = name.strip(), value.strip()
        if not sep or not name or not value:
            raise StudioError(f"--param takes NAME=VALUE, got {pair!r}")
        if name in params:
            raise StudioError(f"--param {name} is given twice")
        params[name] = value
    return params


def _motion(args: argparse.Namespace) -> int:
    from app.core.motions.library import MOTIONS, resolve_params, run_motion

    if args.name == "list":
        if args.json:
            rows = [
                {
                    "name": spec.name,
                    "description": spec.description,
                    "params": [param.to_json() for param in spec.params],
                }
                for spec in MOTIONS.values()
            ]
            print(json.dumps(rows, indent=2))
            return 0
        for spec in MOTIONS.values():
            print(f"{spec.name:15s} {spec.description}")
            for param in spec.params:
                unit = f" [{param.unit}]" if param.unit else ""
                default = "auto" if param.default is None else param.default
                print(f"    {param.name}={default}{unit}  {param.help}")
        return 0

    from app.core.motions.csv_files import write_trajectory_csv
    from app.core.robot.loading import load_robot

    params = resolve_params(args.name, _params(args.param))  # bad names fail before loading
    robot = load_robot(args.robot, package_roots=tuple(args.package_root), feet=_feet(args.feet))
    result = run_motion(robot, args.name, dt=args.dt, **_params(args.param))
    traj = result.trajectory
    if args.out is not None:
        write_trajectory_csv(traj, args.out, robot)
    summary = result.summary()
    if args.json:
        report = {
            "ok": True,
            "motion": args.name,
            "robot": robot.name,
            "params": params,
            "dt_s": traj.dt,
            "duration_s": traj.duration,
            "n_samples": traj.n_samples,
            "out": None if args.out is None else str(args.out),
            "n_warnings": len(result.warnings),
            "notes": list(result.notes),
            "warnings": list(summary[len(result.notes) :]),
        }
        print(json.dumps(report, indent=2))
    else:
        target = f" -> {args.out}" if args.out is not None else " (no --out: nothing written)"
        print(
            f"{args.name} on {robot.name}: {traj.n_samples} samples, {traj.duration:.2f} s "
            f"at dt {traj.dt:g} s{target}"
        )
        for line in summary[:MAX_WARNING_LINES]:
            print(f"warning: {line}", file=sys.stderr)
        if len(summary) > MAX_WARNING_LINES:
            print(
                f"warning: … {len(summary) - MAX_WARNING_LINES} more (--json lists them all)",
                file=sys.stderr,
            )
    return 0


def _add_compensation_commands(sub) -> None:
    """The `compensate` and `calibrate` subcommands (servo spring/clearance compensation)."""
    compensate = sub.add_parser(
        "compensate",
        help="servo commands q + k·τ (+ φ·sign) for a motion and its torque feed-forward",
    )
    compensate.add_argument("trajectory", type=Path, help="motion CSV (biped-studio motion --out)")
    compensate.add_argument("--robot", default=DEFAULT_ROBOT, help="built-in name or URDF path")
    compensate.add_argument(
        "--tau", type=Path, required=True, help="torque CSV: t [s], tau:<joint> [N·m]…, status"
    )
    source = compensate.add_mutually_exclusive_group(required=True)
    source.add_argument(
        "--coeffs", type=Path, help="k.toml: [joints.<name>] k_deg_per_Nm, phi_deg, enabled"
    )
    source.add_argument(
        "--preset",
        choices=("table3", "table2"),
        help="the paper's coefficients: Table 3 (servos 2, 3, 8, 9) or Table 2 (all 12)",
    )
    compensate.add_argument(
        "--clearance", action="store_true", help="with --preset table3: add φ = 8° (eq 23)"
    )
    compensate.add_argument("--out", type=Path, default=None, help="command CSV to write")
    compensate.add_argument("--json", action="store_true")
    _robot_options(compensate)
    calibrate = sub.add_parser(
        "calibrate", help="fit each servo's k from measured commands, angles and torques"
    )
    calibrate.add_argument(
        "measured", type=Path, help="CSV with header frame,joint,q_cmd_deg,q_meas_deg,tau_Nm"
    )
    calibrate.add_argument(
        "--min-tau", type=float, default=None, help="smallest useful max |τ| [N·m] (0.05)"
    )
    calibrate.add_argument(
        "--resolution-deg", type=float, default=None, help="encoder step [°] (0.078125)"
    )
    calibrate.add_argument(
        "--out", type=Path, default=None, help="write the identifiable k as a k.toml"
    )
    calibrate.add_argument("--json", action="store_true")


def _compensate(args: argparse.Namespace) -> int:
    import numpy as np

    from app.core.motions.csv_files import read_trajectory_csv
    from app.core.robot.loading import load_robot
    from app.core.servo.compensation import command_limit_violations, compensated_command
    from app.core.servo.files import (
        read_coefficients_toml,
        read_torque_csv,
        write_command_csv,
    )
    from app.core.servo.model import joint_angles
    from app.core.servo.presets import paper_table2_preset, paper_table3_preset

    if args.clearance and args.preset != "table3":
        raise StudioError("--clearance goes with --preset table3 (a k.toml sets phi_deg itself)")
    robot = load_robot(args.robot, package_roots=tuple(args.package_root), feet=_feet(args.feet))
    traj = read_trajectory_csv(args.trajectory, robot)
    torques = read_torque_csv(args.tau, robot.joint_names)
    if len(torques.t) != traj.n_samples:
        raise StudioError(
            f"{args.tau} has {len(torques.t)} samples but {args.trajectory} has {traj.n_samples}"
        )
    t_tau = torques.t - torques.t[0]
    worst = int(np.argmax(np.abs(t_tau - traj.t)))
    if abs(t_tau[worst] - traj.t[worst]) > 1e-3 * traj.dt + 1e-9:
        raise StudioError(
            f"{args.tau}: sample {worst} is at t = {torques.t[worst]:g} s, the motion's at "
            f"{traj.t[worst]:g} s; the torques must come from this motion"
        )
    if args.preset == "table3":
        params = paper_table3_preset(robot, clearance=args.clearance)
    elif args.preset == "table2":
        params = paper_table2_preset(robot)
    else:
        params = read_coefficients_toml(args.coeffs).for_joints(robot.joint_names)
    q_plan = joint_angles(robot, traj.q)
    q_cmd = compensated_command(q_plan, torques.tau_Nm, params)
    lower = np.array([joint.lower for joint in robot.joints])
    upper = np.array([joint.upper for joint in robot.joints])
    warnings = command_limit_violations(params, q_cmd, lower, upper)
    odd = sorted({s for s in torques.status if s and s.lower() not in ("ok", "solved")})
    for status in odd:
        count = sum(s == status for s in torques.status)
        warnings.append(f"{count} torque sample(s) have status {status!r}")
    if args.out is not None:
        write_command_csv(args.out, traj.t, robot.joint_names, q_cmd)
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
        report = {
            "ok": True,
            "robot": robot.name,
            "n_samples": traj.n_samples,
            "clearance_sign": params.clearance_sign,
            "compensated": joints,
            "notes": list(params.notes),
            "warnings": warnings,
            "out": None if args.out is None else str(args.out),
        }
        print(json.dumps(report, indent=2))
        return 0
    target = f" -> {args.out}" if args.out is not None else " (no --out: nothing written)"
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


def _calibrate(args: argparse.Namespace) -> int:
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
        try:
            args.out.write_text(params.to_toml(), encoding="utf-8")
        except OSError as error:
            raise StudioError(f"cannot write {args.out}: {error.strerror}") from None
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


def _add_feedforward_command(sub) -> None:
    feedforward = sub.add_parser(
        "feedforward",
        help="joint torques of a motion CSV by the whole-body QP (LQR CoM, friction pyramids)",
    )
    feedforward.add_argument("trajectory", type=Path, help="motion CSV (as written by `motion`)")
    feedforward.add_argument("--robot", default=DEFAULT_ROBOT, help="built-in name or URDF path")
    feedforward.add_argument(
        "--out", type=Path, default=None, help="torque CSV: t [s], tau:<joint> [N·m]…, status"
    )
    feedforward.add_argument("--json", action="store_true")
    _robot_options(feedforward)


def _feedforward(args: argparse.Namespace) -> int:
    import time

    import numpy as np

    from app.core.dynamics.wbc import torque_feedforward, write_torque_csv
    from app.core.motions.csv_files import read_trajectory_csv
    from app.core.robot.loading import load_robot

    robot = load_robot(args.robot, package_roots=tuple(args.package_root), feet=_feet(args.feet))
    traj = read_trajectory_csv(args.trajectory, robot)
    begin = time.perf_counter()
    ff = torque_feedforward(robot, traj)
    seconds = time.perf_counter() - begin
    if args.out is not None:
        write_torque_csv(args.out, ff)
    bad = [int(k) for k in ff.infeasible_samples]
    peaks = np.max(np.abs(ff.tau_Nm), axis=0, initial=0.0, where=np.isfinite(ff.tau_Nm))
    if args.json:
        report = {
            "ok": True,
            "robot": robot.name,
            "trajectory": str(args.trajectory),
            "n_samples": traj.n_samples,
            "out": None if args.out is None else str(args.out),
            "max_abs_tau_Nm": {n: float(p) for n, p in zip(ff.joint_names, peaks, strict=True)},
            "infeasible_samples": bad,
            "first_problems": [
                {"index": k, "status": ff.status[k]} for k in bad[:MAX_WARNING_LINES]
            ],
            "solve_time_s": seconds,
            "qp_time_median_ms": float(np.median(ff.qp_time_s) * 1e3),
            "qp_time_p95_ms": float(np.percentile(ff.qp_time_s, 95) * 1e3),
            "notes": list(ff.notes),
        }
        print(json.dumps(report, indent=2))
        return 0
    worst = int(np.argmax(peaks))
    target = f" -> {args.out}" if args.out is not None else " (no --out: nothing written)"
    print(
        f"feedforward {traj.name} on {robot.name}: {traj.n_samples} samples in {seconds:.2f} s, "
        f"{len(bad)} not solved, max |tau| {peaks[worst]:.3g} N·m ({ff.joint_names[worst]}){target}"
    )
    for line in [*ff.notes, *(f"sample {k}: {ff.status[k]}" for k in bad)][:MAX_WARNING_LINES]:
        print(f"warning: {line}", file=sys.stderr)
    if len(ff.notes) + len(bad) > MAX_WARNING_LINES:
        print("warning: … more (--json lists every sample not solved)", file=sys.stderr)
    return 0


def _add_plan_command(sub) -> None:
    plan = sub.add_parser(
        "plan",
        help="plan the gait paper's symmetric walking gait for dircon_biped (DIRCON, IPOPT)",
    )
    plan.add_argument(
        "--config", type=Path, default=None, help="plan.toml: GaitSettings fields (K0 = 6.5, …)"
    )
    plan.add_argument(
        "--baseline", action="store_true", help="the original DIRCON planner (no symmetry)"
    )
    plan.add_argument("--out", type=Path, default=None, help="gait CSV to write (100 Hz)")
    plan.add_argument("--dt", type=float, default=0.01, help="CSV sample time step [s]")
    plan.add_argument("--json", action="store_true")


def _plan(args: argparse.Namespace) -> int:
    from app.core.collocation.dircon import (
        GaitProblem,
        GaitSettings,
        read_settings_toml,
        to_trajectory,
    )
    from app.core.motions.csv_files import write_trajectory_csv
    from app.core.robot.loading import load_robot

    values = read_settings_toml(args.config) if args.config is not None else {}
    if args.baseline:
        values["baseline"] = True
    settings = GaitSettings.from_mapping(values, source=str(args.config or "settings"))
    if not args.dt > 0.0:
        raise StudioError(f"--dt must be > 0, got {args.dt}")
    robot = load_robot("dircon_biped")
    problem = GaitProblem(robot, settings.knots, settings.baseline)
    result = problem.solve(settings)
    if not result.converged:  # the one-line reason, without the GUI's "last iterate" note
        raise StudioError(f"{result.status.split(';')[0]} ({result.iterations} iterations)")
    if args.out is not None:
        write_trajectory_csv(to_trajectory(robot, result, dt=args.dt), args.out, robot)
    summary = result.summary()
    if args.json:
        report = {
            "ok": True,
            **summary,
            "build_s": problem.build_s,
            "sr": result.sr,
            "out": None if args.out is None else str(args.out),
        }
        print(json.dumps(report, indent=2))
        return 0
    lsp, rsp = result.step_lengths_m
    target = f" -> {args.out}" if args.out is not None else " (no --out: nothing written)"
    kind = "baseline DIRCON" if settings.baseline else "symmetric"
    print(
        f"{kind} gait: {result.status} in {result.solve_s:.2f} s ({result.iterations} iterations, "
        f"built in {problem.build_s:.1f} s); max |tau| {result.max_abs_tau_Nm:.2f} N·m, "
        f"steps {lsp:.3f} / {rsp:.3f} m, slack0 {result.slack0:.3g}, SR {result.sr:.3f}{target}"
    )
    return 0
