"""`plan`: the symmetric DIRCON gait of a biped, and optionally a whole-body walk of N steps."""

from __future__ import annotations

import argparse
import dataclasses
import json
from pathlib import Path

from app.cli.common import (
    add_output_arguments,
    add_robot_options,
    load_robot_from_args,
    output_target,
)
from app.core.budgets import check_dt, check_samples
from app.core.errors import StudioError

MAX_STEPS = 100
"""Most steps `plan --steps` walks."""
PLAN_ROBOT = "dircon_biped"
"""The robot `plan` uses without --robot: the gait paper's."""


def add_parser(sub) -> None:
    plan = sub.add_parser(
        "plan",
        help="plan the gait paper's symmetric walking gait (DIRCON, IPOPT) for a biped, and "
        "optionally a whole-body walk of N steps",
    )
    plan.add_argument(
        "--robot", default=PLAN_ROBOT, help=f"built-in name or URDF path (default {PLAN_ROBOT})"
    )
    add_robot_options(plan)
    plan.add_argument(
        "--config",
        type=Path,
        default=None,
        help="plan.toml: GaitSettings fields (K0 = 6.5, …); others default for the robot",
    )
    plan.add_argument(
        "--baseline", action="store_true", help="the original DIRCON planner (no symmetry)"
    )
    plan.add_argument(
        "--steps",
        type=int,
        default=0,
        help="walk this many steps from rest to rest (3-D, lateral sway); 0: one gait cycle",
    )
    plan.add_argument(
        "--step-width", type=float, default=None, help="walk: lateral distance of the feet [m]"
    )
    plan.add_argument(
        "--compare",
        action="store_true",
        help="also solve the baseline and report both beside the paper's Table 4 (ratios)",
    )
    plan.add_argument(
        "--simulate",
        action="store_true",
        help="with --compare: walk both gaits (--steps, else 6 steps), simulate each on the "
        "robot's sized servos (eq 7 on the drive torque) and report their SR from electrical "
        "energy beside Table 4's",
    )
    plan.add_argument("--dt", type=float, default=0.01, help="CSV sample time step [s]")
    add_output_arguments(plan, "gait or walk CSV to write")


def run(args: argparse.Namespace) -> int:
    from app.core.collocation.defaults import PAPER_ROBOT, robot_gait_defaults
    from app.core.collocation.dircon import GaitProblem, read_settings_toml, to_trajectory
    from app.core.collocation.settings import GaitSettings
    from app.core.motions.csv_files import write_trajectory_csv

    check_dt(args.dt, "--dt")  # before the solve, not after minutes of it
    if not 0 <= args.steps <= MAX_STEPS:
        raise StudioError(f"--steps must be in [0, {MAX_STEPS}], got {args.steps}")
    if args.simulate and (not args.compare or args.baseline):
        raise StudioError("--simulate goes with --compare (and not --baseline)")
    values = read_settings_toml(args.config) if args.config is not None else {}
    if args.baseline:
        values["baseline"] = True
    robot = load_robot_from_args(args)
    defaults = robot_gait_defaults(robot)
    settings = GaitSettings.from_mapping(
        values, source=str(args.config or "settings"), base=defaults.settings
    )
    check_samples(
        settings.H_s * max(1, args.steps) / args.dt + 1,
        robot.model.nq,
        f"the gait CSV at --dt {args.dt:g} s",
    )
    problem = GaitProblem(robot, settings.knots, settings.baseline)
    result = problem.solve(settings)
    notes = list(defaults.notes)
    if robot.name != PAPER_ROBOT and "step_length_m" not in values:  # robot-derived default
        from app.core.walking.start_fit import fit_default_step

        fit = fit_default_step(problem.model, settings, result, problem.solve)
        settings, result = fit.settings, fit.result
        notes += [] if fit.note is None else [fit.note]
    if not result.converged:  # the one-line reason, without the GUI's "last iterate" note
        reason = result.status.split(";")[0]
        if "iterations" not in reason:
            reason += f" ({result.iterations} iterations)"
        raise StudioError(f"{reason}; {result.blame}" if result.blame else reason)
    comparison, base = None, None
    if args.compare and not settings.baseline:
        comparison, base = _table4_comparison(problem, settings, result)
    walk = None
    if args.steps > 0:
        from app.core.walking.walk import build_walk

        walk = build_walk(
            problem.model, result, steps=args.steps, step_width_m=args.step_width, dt=args.dt
        )
        trajectory = walk.trajectory
    else:
        trajectory = to_trajectory(robot, result, dt=args.dt)
    if comparison is not None and args.simulate:
        from app.cli.plan_simulate import WALK_STEPS, simulated_comparison

        comparison["simulated"] = simulated_comparison(
            robot, problem.model, {"symmetric": result, "baseline": base},
            args.steps or WALK_STEPS, args.step_width, args.dt, walk,
        )  # fmt: skip
    if args.out is not None:
        write_trajectory_csv(trajectory, args.out, robot)
    summary = result.summary()
    if args.json:
        report = {
            "ok": True,
            "robot": robot.name,
            **summary,
            "build_s": problem.build_s,
            "settings_notes": notes,
            "step_length_m": settings.step_length_m,
            "table4": comparison,
            "walk": None if walk is None else _walk_json(walk, args.steps),
            "out": None if args.out is None else str(args.out),
        }
        print(json.dumps(report, indent=2))
        return 0
    lsp, rsp = result.step_lengths_m
    target = output_target(args.out)
    kind = "baseline DIRCON" if settings.baseline else "symmetric"
    walked = (
        "" if walk is None else f"; walk of {args.steps} steps, {walk.trajectory.duration:.2f} s"
    )
    print(
        f"{robot.name}: {kind} gait: {result.status} in {result.solve_s:.2f} s "
        f"({result.iterations} iterations, built in {problem.build_s:.1f} s); max |tau| "
        f"{result.max_abs_tau_Nm:.2f} N·m, steps {lsp:.3f} / {rsp:.3f} m, slack0 "
        f"{result.slack0:.3g}, SR {result.sr:.3f} ({result.sr_incl_impacts:.3f} with impacts)"
        f"{walked}{target}"
    )
    if comparison is not None:
        for row in comparison["rows"]:  # type: ignore[attr-defined]
            print(
                f"{row['name']}: symmetric / baseline {row['ours_ratio']:.3f} (ours), "
                f"{row['paper_ratio']:.3f} (paper, Table 4)"
            )
        print(_bound_line(comparison))
        print(f"compared: {comparison['what']}")
        if "simulated" in comparison:
            from app.cli.plan_simulate import simulated_lines

            print("\n".join(simulated_lines(comparison["simulated"])))  # type: ignore[arg-type]
    for note in (*notes, *(() if walk is None else walk.notes)):
        print(f"note: {note}")
    return 0


def _table4_comparison(problem, settings, result) -> tuple[dict[str, object], object]:
    """The baseline solved beside the symmetric `result` (and again without its torque bound
    where that bound sets its peak), compared as in the paper's Table 4; and the baseline."""
    from app.core.collocation.dircon import GaitProblem
    from app.core.collocation.table4 import LIFTED_BOUND_FACTOR, bound_binds, table4_comparison

    base_settings = dataclasses.replace(settings, baseline=True)
    base = GaitProblem(problem.model, settings.knots, True).solve(base_settings)
    if not base.converged:
        blame = f"; {base.blame}" if base.blame else ""
        raise StudioError(f"baseline: {base.status.split(';')[0]} ({base.iterations} its){blame}")
    unbounded = None
    if bound_binds(base):  # its peak is the bound: solve again without it to read its own
        lifted = dataclasses.replace(
            base_settings, tau_max_Nm=LIFTED_BOUND_FACTOR * base_settings.tau_max_Nm
        )
        unbounded = GaitProblem(problem.model, settings.knots, True).solve(lifted)
    return table4_comparison(result, base, unbounded), base


def _walk_json(walk, steps: int) -> dict:
    """The walk's part of `plan --json`."""
    return {
        "steps": steps,
        "samples": walk.trajectory.n_samples,
        "duration_s": walk.trajectory.duration,
        "step_width_m": walk.step_width_m,
        "footprints": [dataclasses.asdict(f) for f in walk.footprints],
        "notes": list(walk.notes),
    }


def _bound_line(comparison: dict) -> str:
    """Whether the torque bound sets either gait's peak, and the baseline's peak without it."""
    bounds, binds = comparison["torque_bound_Nm"], comparison["bound_binds"]
    line = "torque bound " + ", ".join(
        f"{name} {bound:g} N·m ({'binds: its peak is the bound' if bind else 'not reached'})"
        for name, bound, bind in zip(("symmetric", "baseline"), bounds, binds, strict=True)
    )
    lifted = comparison["baseline_bound_lifted"]
    if lifted is not None:
        state = "" if lifted["converged"] else ", not converged"
        line += (
            f"; baseline with the bound lifted to {lifted['torque_bound_Nm']:g} N·m: max |τ| "
            f"{lifted['max_abs_tau_Nm']:.2f} N·m{state}, symmetric / baseline "
            f"{lifted['ratio']:.3f}, SR {lifted['sr_incl_impacts']:.3f}"
        )
    return line
