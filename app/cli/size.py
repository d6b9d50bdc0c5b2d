"""`size`: per joint, the lightest (or cheapest) catalogue servo that holds a motion's work."""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path
from typing import TYPE_CHECKING

from app.cli.common import (
    MotionInputs,
    add_motion_command,
    add_output_arguments,
    add_torques_argument,
    add_user_servos_argument,
    motion_inputs,
    print_report,
)
from app.core.errors import StudioError

if TYPE_CHECKING:
    import numpy as np

    from app.core.servo.catalogue import ServoRecord
    from app.core.servo.sizing import Sizing
    from app.core.servo.sizing_work import Work


def add_parser(sub) -> None:
    size = add_motion_command(sub, "size")
    add_torques_argument(size, "a project's torques, else computed by the whole-body QP")
    size.add_argument(
        "--also",
        type=Path,
        action="append",
        default=[],
        metavar="MOTION.csv",
        help="another motion of the same robot to size against too (repeatable; its torques "
        "by the whole-body QP): a servo and its kp must hold every motion",
    )
    size.add_argument(
        "--margin",
        type=float,
        default=0.3,
        help="headroom asked of every point and of the RMS torque (0.3: 30 %%)",
    )
    size.add_argument(
        "--continuous-fraction",
        type=float,
        default=None,
        help="the continuous (thermal) rating assumed where a servo publishes none, as a "
        "fraction of its stall torque (default 0.25)",
    )
    size.add_argument(
        "--by", choices=("mass", "price"), default="mass", help="what to minimise (mass)"
    )
    add_user_servos_argument(size)
    size.add_argument(
        "--servo-toml",
        type=Path,
        default=None,
        metavar="OUT",
        help="write the choice as a servo.toml for simulate --servo OUT --preset parts (sized "
        "then over the servos the simulation can run; the closest where none holds a joint)",
    )
    size.add_argument(
        "--kp",
        type=float,
        default=None,
        help="with --servo-toml: one firmware P gain for every joint, overriding the kp the "
        "sizing chose per joint (the parts' stiffness, hence whether the robot stands, grows "
        "with it)",
    )
    size.add_argument(
        "--stand-margin",
        type=float,
        default=None,
        help="per joint the smallest kp whose stiffness makes the robot stand by the stand "
        "check's linearised balance, with this margin: it still stands with every leg servo "
        "(1 + margin)× softer (default 0.5)",
    )
    size.add_argument(
        "--max-sag-deg",
        type=float,
        default=None,
        help="the largest quasi-static sag (load + the servo's friction)/K a joint may have in "
        "any motion, which the chosen kp keeps (default 2°)",
    )
    size.add_argument(
        "--time", action="store_true", help="print how long the sizing itself took (not torques)"
    )
    add_output_arguments(size, None)


def run(args: argparse.Namespace) -> int:
    from app.core.servo.kp_sizing import (
        MAX_SAG_DEG,
        STAND_MARGIN,
        check_max_sag,
        check_stand_margin,
        size_with_kp,
    )
    from app.core.servo.sizing import CONTINUOUS_FRACTION_OF_STALL, check_fraction, check_margin
    from app.core.servo.sizing_work import motion_work

    margin = check_margin(args.margin)
    fraction = check_fraction(
        CONTINUOUS_FRACTION_OF_STALL
        if args.continuous_fraction is None
        else args.continuous_fraction
    )
    stand_margin = check_stand_margin(
        STAND_MARGIN if args.stand_margin is None else args.stand_margin
    )
    max_sag_deg = check_max_sag(MAX_SAG_DEG if args.max_sag_deg is None else args.max_sag_deg)
    catalogue, left_out = _catalogue(args)
    inputs = motion_inputs(args)
    robot, traj = inputs.robot, inputs.trajectory
    tau, infeasible = _torques(args, inputs)
    motion = motion_work(robot, traj, tau, infeasible)
    works = {"motion": motion, **_project_gaits(args, robot), **_also(args.also, robot)}
    begin = time.perf_counter()
    sizing = size_with_kp(
        robot,
        works,
        float(traj.t[-1] - traj.t[0]),
        catalogue,
        margin,
        args.by,
        continuous_fraction=fraction,
        trajectory=traj,
        stand_margin=stand_margin,
        max_sag_deg=max_sag_deg,
    )
    seconds = time.perf_counter() - begin
    notes = list(sizing.notes)
    if args.servo_toml is not None:
        notes += _write_parts(args.servo_toml, sizing, args.kp, left_out)
    if motion.flagged:
        notes.append(
            f"{len(motion.flagged)} flagged sample(s) left out (not solved, or a joint over its "
            "speed limit: torques there are artefacts)"
        )
    sized = _Sized(inputs, catalogue, works, sizing, notes, seconds)
    if args.json:
        return print_report(_json_fields(args, sized))
    _print_text(args, sized, margin)
    return 0


@dataclasses.dataclass(frozen=True)
class _Sized:
    """What `size` computed, for its report."""

    inputs: MotionInputs
    catalogue: dict[str, ServoRecord]
    """The servos sized over."""
    works: dict[str, Work]
    """The motion's work and a project's planned gaits'."""
    sizing: Sizing
    notes: list[str]
    seconds: float
    """How long the sizing itself took [s] (torques excluded)."""


def _catalogue(args: argparse.Namespace) -> tuple[dict[str, ServoRecord], list[str]]:
    """The servos to size over (the catalogue with --servos'; with --servo-toml only those
    the simulation can run), and the keys left out for that."""
    from app.core.servo.catalogue import load_catalogue, read_user_servos, with_user_servos
    from app.core.servo.sized_parts import check_kp

    catalogue = load_catalogue()
    for path in args.servos:
        catalogue = with_user_servos(catalogue, read_user_servos(path))
    if args.kp is not None and args.servo_toml is None:
        raise StudioError("--kp goes with --servo-toml (the firmware P gain it writes)")
    check_kp(args.kp)
    if args.servo_toml is None:
        return catalogue, []
    from app.core.servo.choice import runnable as runnable_records

    runnable = runnable_records(catalogue)  # a kp law and firmware, or a continuous point
    if not args.servo_toml.resolve().parent.is_dir():
        raise StudioError(f"--servo-toml {args.servo_toml}: its folder does not exist")
    return runnable, sorted(set(catalogue) - set(runnable))


def _json_fields(args: argparse.Namespace, sized: _Sized) -> dict[str, object]:
    """`size --json`'s answer."""
    from app.core.servo.sizing_totals import totals

    traj = sized.inputs.trajectory
    fields = {
        "robot": sized.inputs.robot.name,
        "motion": sized.inputs.source,
        "n_samples": traj.n_samples,
        "n_servos": len(sized.catalogue),
        "works": list(sized.works),
        **sized.sizing.to_json(),
        "totals": dataclasses.asdict(totals(sized.sizing, sized.catalogue)),
        "notes": sized.notes,
    }
    if args.time:
        fields["sizing_time_s"] = sized.seconds
    return fields


def _print_text(args: argparse.Namespace, sized: _Sized, margin: float) -> None:
    """The sizing's line, a line per joint (its servo, or the closest and why not), the total
    and the notes."""
    from app.core.servo.sizing_totals import totals

    robot, traj, sizing = sized.inputs.robot, sized.inputs.trajectory, sized.sizing
    gaits = [label for label in sized.works if label.endswith(" gait")]
    also = [label for label in sized.works if label != "motion" and label not in gaits]
    print(
        f"sizing {traj.name} on {robot.name} ({traj.n_samples} samples"
        + (f"; and the project's {', '.join(gaits)}" if gaits else "")
        + (f"; and {', '.join(also)}" if also else "")
        + f") over {len(sized.catalogue)} "
        f"servos, margin {margin:.0%}, by {args.by}: "
        f"{len(robot.joint_names) - len(sizing.unsized)} of {len(robot.joint_names)} joints sized"
    )
    for joint in sizing.joints:
        if joint.choice is not None:
            c = joint.check(joint.choice)
            rating = "assumed" if c.continuous_assumed else "rated"
            print(
                f"  {joint.joint:20s} {c.servo:12s} peak margin {c.peak_margin:+6.0%}  "
                f"RMS {c.rms_torque_Nm:6.3f} N·m of {c.continuous_torque_Nm:.3g} ({rating})"
                + _stiffness_text(c.stiffness)
            )
        else:
            best = max(joint.checks, key=lambda c: min(c.peak_margin, c.thermal_margin))
            print(
                f"  {joint.joint:20s} NO SERVO holds it; closest {best.servo}: "
                + "; ".join(best.violations())
            )
    print(f"total: {totals(sizing, sized.catalogue).line()}")
    for note in sized.notes:
        print(f"note: {note}")
    if args.time:
        print(f"sizing took {sized.seconds * 1e3:.1f} ms (torques excluded)")


def _stiffness_text(stiffness) -> str:
    """ "  kp 95: K 166 N·m/rad, sag 1.0°" (or why there is none)."""
    if stiffness is not None and stiffness.stated:
        return (
            f"  no kp law: K {stiffness.stiffness_Nm_per_rad:.3g} N·m/rad stated, "
            f"sag {stiffness.sag_deg:.2g}°"
        )
    if stiffness is None or not stiffness.checked:
        return "  kp: not checked (no firmware constants)"
    return (
        f"  kp {stiffness.kp:g}: K {stiffness.stiffness_Nm_per_rad:.3g} N·m/rad, "
        f"sag {stiffness.sag_deg:.2g}°"
    )


def _torques(args: argparse.Namespace, inputs) -> tuple[np.ndarray, tuple[int, ...]]:
    """(τ (T, n) [N·m], samples without a QP solution) from --tau, the project, or the QP."""
    import numpy as np

    robot, traj = inputs.robot, inputs.trajectory
    if args.tau is not None:
        from app.core.servo.files import read_torque_csv

        table = read_torque_csv(args.tau, robot.joint_names)
        if len(table.t) != traj.n_samples or not np.allclose(
            table.t - table.t[0], traj.t, atol=1e-3 * traj.dt
        ):
            raise StudioError(
                f"{args.tau} does not have the motion's {traj.n_samples} sample times"
            )
        bad = tuple(k for k, s in enumerate(table.status) if s not in ("", "solved"))
        return table.tau_Nm, bad
    ff = inputs.feedforward
    if ff is None:
        from app.core.dynamics.wbc import torque_feedforward

        ff = torque_feedforward(robot, traj)
    return ff.tau_Nm, tuple(int(k) for k in ff.infeasible_samples)


def _also(paths: list[Path], robot) -> dict:
    """Each --also motion's work (label: its file name), torques by the whole-body QP."""
    if not paths:  # the QP's libraries load only for a motion whose torques it computes
        return {}
    from app.core.dynamics.wbc import torque_feedforward
    from app.core.motions.csv_files import read_trajectory_csv
    from app.core.servo.sizing_work import motion_work

    out = {}
    for path in paths:
        if path.name in out or path.name == "motion":
            raise StudioError(f"--also {path}: a motion of that name is already sized")
        traj = read_trajectory_csv(path, robot)
        ff = torque_feedforward(robot, traj)
        out[path.name] = motion_work(
            robot, traj, ff.tau_Nm, [int(k) for k in ff.infeasible_samples]
        )
    return out


def _project_gaits(args: argparse.Namespace, robot) -> dict:
    """A project's planned gaits as works on the robot's joints (app.core.servo.sizing_work);
    {} for a CSV."""
    from app.cli.common import PROJECT_SUFFIX

    if Path(args.trajectory).suffix.lower() != PROJECT_SUFFIX:
        return {}
    from app.core.projects.files import read_project
    from app.core.servo.sizing_work import gait_work

    project = read_project(args.trajectory)
    out = {}
    for label, gait in (
        ("symmetric gait", project.gait_symmetric),
        ("baseline gait", project.gait_baseline),
    ):
        work = None if gait is None else gait_work(robot, gait)
        if work is not None:
            out[label] = work
    return out


def _write_parts(path: Path, sizing, kp: float | None, left_out: list[str]) -> list[str]:
    """The choice written as a servo.toml (app.core.servo.sized_parts), and what to note."""
    from app.core.servo.sized_parts import sized_parts

    parts = sized_parts(sizing, kp)
    path.write_text(parts.text, encoding="utf-8")
    notes = [f"servo parts written to {path} (simulate --servo {path} --preset parts)"]
    if left_out:
        notes.append(
            f"sized over the servos the simulation can run; left out {', '.join(left_out)}"
        )
    if parts.closest:
        notes.append(
            f"no servo holds {', '.join(parts.closest)}: the file gives each the closest one"
        )
    if parts.softer:
        notes.append(
            f"--kp {kp:g} is below the kp the stiffness needs on {', '.join(parts.softer)} "
            "(to stand, or within the sag bound)"
        )
    return notes
