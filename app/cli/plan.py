"""`plan`: the symmetric DIRCON gait of a biped, and optionally a whole-body walk of N steps."""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path
from typing import TYPE_CHECKING

from app.cli.common import (
    add_output_arguments,
    add_robot_argument,
    load_robot_from_args,
    output_target,
    print_report,
    written,
)
from app.core.budgets import check_dt, check_samples
from app.core.errors import StudioError

if TYPE_CHECKING:
    from app.core.collocation.dircon import GaitProblem
    from app.core.collocation.result import GaitResult
    from app.core.collocation.settings import GaitSettings
    from app.core.motions.trajectory import Trajectory
    from app.core.robot.model import RobotModel
    from app.core.walking.walk import Walk

MAX_STEPS = 100
"""Most steps `plan --steps` walks."""
PLAN_ROBOT = "dircon_biped"
"""The robot `plan` uses without --robot: the gait paper's."""


def add_parser(sub) -> None:
    plan = sub.add_parser("plan")
    add_robot_argument(plan, PLAN_ROBOT)
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


@dataclasses.dataclass
class _Planned:
    """What `plan` computed on the robot, in the order it is reported."""

    robot: RobotModel
    problem: GaitProblem
    settings: GaitSettings
    result: GaitResult
    notes: list[str]
    """The settings' notes (robot-derived defaults, a shortened default step)."""
    walk: Walk | None = None
    trajectory: Trajectory | None = None
    """The walk's, or one gait cycle's (what --out writes)."""
    comparison: dict[str, object] | None = None
    """Table 4's comparison (--compare), with the simulated walks (--simulate)."""


def run(args: argparse.Namespace) -> int:
    _check_args(args)
    planned = _planned_gait(args, load_robot_from_args(args))
    base = None
    if args.compare and not planned.settings.baseline:
        planned.comparison, base = _table4_comparison(
            planned.problem, planned.settings, planned.result
        )
    _walk(args, planned)
    if planned.comparison is not None and args.simulate:
        from app.cli.plan_simulate import WALK_STEPS, simulated_comparison

        planned.comparison["simulated"] = simulated_comparison(
            planned.robot, planned.problem.model, {"symmetric": planned.result, "baseline": base},
            args.steps or WALK_STEPS, args.step_width, args.dt, planned.walk,
        )  # fmt: skip
    if args.out is not None and planned.trajectory is not None:
        from app.core.motions.csv_files import write_trajectory_csv

        write_trajectory_csv(planned.trajectory, args.out, planned.robot)
    if args.json:
        return print_report(_json_fields(args, planned))
    _print_text(args, planned)
    return 0


def _check_args(args: argparse.Namespace) -> None:
    """The options that need no robot, checked before the solve (not after minutes of it)."""
    check_dt(args.dt, "--dt")
    if not 0 <= args.steps <= MAX_STEPS:
        raise StudioError(f"--steps must be in [0, {MAX_STEPS}], got {args.steps}")
    if args.simulate and (not args.compare or args.baseline):
        raise StudioError("--simulate goes with --compare (and not --baseline)")


def _planned_gait(args: argparse.Namespace, robot: RobotModel) -> _Planned:
    """The gait solved with --config's settings over the robot's defaults (a robot-derived
    step shortened until its walk can start); StudioError (one line) when it did not converge."""
    from app.core.collocation.defaults import PAPER_ROBOT, robot_gait_defaults
    from app.core.collocation.dircon import GaitProblem, read_settings_toml
    from app.core.collocation.settings import GaitSettings

    values = read_settings_toml(args.config) if args.config is not None else {}
    if args.baseline:
        values["baseline"] = True
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
    return _Planned(robot, problem, settings, result, notes)


def _walk(args: argparse.Namespace, planned: _Planned) -> None:
    """The walk of --steps steps (none for 0) and the trajectory --out writes."""
    if args.steps > 0:
        from app.core.walking.walk import build_walk

        planned.walk = build_walk(
            planned.problem.model,
            planned.result,
            steps=args.steps,
            step_width_m=args.step_width,
            dt=args.dt,
        )
        planned.trajectory = planned.walk.trajectory
    else:
        from app.core.collocation.dircon import to_trajectory

        planned.trajectory = to_trajectory(planned.robot, planned.result, dt=args.dt)


def _json_fields(args: argparse.Namespace, planned: _Planned) -> dict[str, object]:
    """`plan --json`'s answer."""
    walk, settings = planned.walk, planned.settings
    return {
        "robot": planned.robot.name,
        **planned.result.summary(),
        "build_s": planned.problem.build_s,
        "settings_notes": planned.notes,
        "step_length_m": settings.step_length_m,
        "table4": planned.comparison,
        "walk": None if walk is None else _walk_json(walk, args.steps),
        "out": written(args.out),
    }


def _print_text(args: argparse.Namespace, planned: _Planned) -> None:
    """The gait's line, Table 4's comparison (--compare) and the notes."""
    result, walk, comparison = planned.result, planned.walk, planned.comparison
    lsp, rsp = result.step_lengths_m
    kind = "baseline DIRCON" if planned.settings.baseline else "symmetric"
    walked = (
        "" if walk is None else f"; walk of {args.steps} steps, {walk.trajectory.duration:.2f} s"
    )
    print(
        f"{planned.robot.name}: {kind} gait: {result.status} in {result.solve_s:.2f} s "
        f"({result.iterations} iterations, built in {planned.problem.build_s:.1f} s); max |tau| "
        f"{result.max_abs_tau_Nm:.2f} N·m, steps {lsp:.3f} / {rsp:.3f} m, slack0 "
        f"{result.slack0:.3g}, SR {result.sr:.3f} ({result.sr_incl_impacts:.3f} with impacts)"
        f"{walked}{output_target(args.out)}"
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
    for note in (*planned.notes, *(() if walk is None else walk.notes)):
        print(f"note: {note}")


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
