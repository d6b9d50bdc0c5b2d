"""`simulate`: a motion on the robot's servos, in MuJoCo, with a fall verdict."""

from __future__ import annotations

import argparse
import dataclasses
import functools
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from app.cli.common import (
    MotionInputs,
    add_coefficients_arguments,
    add_motion_command,
    add_output_arguments,
    add_torques_argument,
    add_user_servos_argument,
    coefficients_from_args,
    motion_inputs,
    output_target,
    print_report,
    written,
)
from app.cli.energy_lines import figures_line, ideal_energy, ideal_line
from app.core.errors import StudioError

if TYPE_CHECKING:
    import numpy as np

PRESETS = ("plan", "uniform", "table3", "table2", "parts")


def add_parser(sub) -> None:
    simulate = add_motion_command(sub, "simulate")
    source = add_coefficients_arguments(
        simulate,
        PRESETS,
        "plan: the plan as it is (no compensation); uniform: k = the servos' compliance "
        "on the legs (1.4 °/(N·m) on the paper's robot, sized to the robot by m·g·h); "
        "table3 / table2: the paper's coefficients; parts: k = 1/K and φ = half the dead band "
        "of the servo parts a --servo file names (eq 23, torque sign)",
        toml_flag="--compensation",
    )
    source.add_argument("--cmd", type=Path, help="servo commands CSV (biped-studio compensate)")
    add_torques_argument(simulate, "computed by the whole-body QP")
    simulate.add_argument(
        "--drive-torque",
        action="store_true",
        help="compensate the servo's whole drive torque τ + D·q̇ + J·q̈ (its back-EMF damping "
        "and rotor inertia, as simulated), not τ alone: a fast motion (a walk) lags its plan "
        "otherwise; same as eq 7 for a slow one (a project's compensation uses the torque "
        "its studio chose)",
    )
    simulate.add_argument(
        "--servo",
        type=Path,
        default=None,
        help="servo.toml: true compliance and dead band (default: the paper's 1.4 °/(N·m), 0.5° "
        "and 6 N·m sized to the robot by m·g·h, on the legs; torque where the URDF gives none), "
        'or catalogue servos per joint (servo = "mx106", kp, vin_V, current_limit_A, '
        "dead_band_deg): the parts' motor law (see biped-studio servos)",
    )
    add_user_servos_argument(simulate)
    simulate.add_argument(
        "--baseline", action="store_true", help="also run the plan uncompensated (in parallel)"
    )
    simulate.add_argument(
        "--servo-masses",
        default=None,
        metavar="COUNTED",
        help="with servo parts: each joint's servo mass replaces the one its URDF link counts "
        "(COUNTED: the catalogue servo the URDF was modelled with, or none: add the masses); "
        "torques are then computed on the new masses",
    )
    simulate.add_argument(
        "--battery-Wh",
        type=float,
        default=None,
        help="with servo parts: a pack's usable energy [Wh]; prints minutes of the motion repeated",
    )
    simulate.add_argument(
        "--balance-feedback",
        action="store_true",
        help="run a servo firmware's balance feedback: every 10 ms the torso's roll/pitch error "
        "(IMU) to offsets on the stance legs' ankle and hip commands (PD, saturated; default "
        "gains: ankles Kp 1, Kd 0.05 s; hips Kp 0.5, Kd 0.02 s; ≤ 10°); the verdict says so",
    )
    simulate.add_argument(
        "--balance-gain",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="with --balance-feedback, a gain (repeatable): ankle_kp, ankle_kd [s], hip_kp, "
        "hip_kd [s], max_offset_deg",
    )
    simulate.add_argument("--friction", type=float, default=0.6, help="floor friction μ")
    simulate.add_argument(
        "--hold",
        choices=("zoh", "linear"),
        default="zoh",
        help="commands held until the next one (zoh) or ramped (linear)",
    )
    simulate.add_argument("--hulls", action="store_true", help="collide the links' convex hulls")
    add_output_arguments(simulate, "simulation CSV to write")


def _torques(args: argparse.Namespace, robot, traj, inputs: MotionInputs):
    import numpy as np

    if args.tau is None and inputs.feedforward is not None:
        return inputs.feedforward.tau_Nm
    if args.tau is None:
        from app.core.dynamics.wbc import torque_feedforward

        return torque_feedforward(robot, traj).tau_Nm
    from app.core.servo.files import read_torque_csv

    table = read_torque_csv(args.tau, robot.joint_names)
    if len(table.t) != traj.n_samples or not np.allclose(
        table.t - table.t[0], traj.t, atol=1e-3 * traj.dt
    ):
        raise StudioError(f"{args.tau} does not have the motion's {traj.n_samples} sample times")
    return table.tau_Nm


def _parts(args: argparse.Namespace, joint_names: tuple[str, ...]):
    """The servo parts of a --servo file that names catalogue servos, else None."""
    if args.servo is None:
        if args.servos:
            raise StudioError("--servos adds servos to the catalogue: name them in a --servo file")
        return None
    from app.core import input_gate
    from app.core.servo.catalogue import load_catalogue, read_user_servos, with_user_servos
    from app.core.servo.parts import ServoPartsError, is_parts_file, parts_from_mapping

    data = input_gate.read_toml(args.servo, ServoPartsError)
    if not is_parts_file(data):
        if args.servos:
            raise StudioError(f"--servos goes with a --servo file that names servos ({args.servo})")
        return None
    catalogue = load_catalogue()
    for path in args.servos:
        catalogue = with_user_servos(catalogue, read_user_servos(path))
    return parts_from_mapping(data, joint_names, catalogue, str(args.servo))


def _stand_check(robot, traj, servo) -> str | None:
    """The stiffness balance at the motion's first pose when it stands on both feet: its one
    line, or None (one foot down, or legs the check does not fit)."""
    from app.core.dynamics.stand_stiffness import StandCheckError, stand_check

    if not (traj.contacts[0, 0] and traj.contacts[0, 1]):
        return None
    try:
        compliance = servo.for_joints(robot.joint_names).compliance_deg_per_Nm
        return stand_check(robot, traj.q[0], compliance).text()
    except StandCheckError:
        return None


def _commands(
    args: argparse.Namespace,
    robot,
    traj,
    inputs: MotionInputs,
    parts,
    from_project: bool,
    load: Callable[[], np.ndarray],
    drive: bool,
):
    """The servo commands to simulate, by label (the plan uncompensated first with
    --baseline), and the label of the main one."""
    from app.core.servo.compensation import compensated_command
    from app.core.servo.model import joint_angles
    from app.core.simulation.files import read_command_csv

    q_plan = joint_angles(robot, traj.q)
    if args.cmd is not None:
        q_cmd, label = read_command_csv(args.cmd, robot.joint_names, traj.n_samples), "commands"
    elif args.preset == "plan":
        q_cmd, label = q_plan, "without compensation"
    elif args.preset == "parts":
        if parts is None:
            raise StudioError('--preset parts needs a --servo file that names servos (servo = "…")')
        q_cmd = compensated_command(q_plan, load(), parts.compensation())
        label = "with compensation" + (" (drive torque)" if drive else "")
    else:
        params = (
            inputs.compensation
            if from_project and inputs.compensation is not None
            else coefficients_from_args(robot, args.preset, args.clearance, args.compensation)
        )
        q_cmd = compensated_command(q_plan, load(), params)
        label = "with compensation" + (" (drive torque)" if drive else "")
    commands = {label: q_cmd}
    if args.baseline and args.preset != "plan":
        commands = {"without compensation": q_plan, **commands}
    return commands, label


def run(args: argparse.Namespace) -> int:
    from app.core.simulation.experiments import clipped_commands, with_note
    from app.core.simulation.files import (
        read_servo_toml,
        sized_servos,
        write_simulation_csv,
    )
    from app.core.simulation.mjcf import SimOptions
    from app.core.simulation.run import simulate_commands

    if args.clearance and args.preset != "table3":
        raise StudioError("--clearance goes with --preset table3 (a k.toml sets phi_deg itself)")
    if args.battery_Wh is not None:
        from app.core.simulation.battery import check_pack_Wh

        check_pack_Wh(args.battery_Wh)
    inputs = motion_inputs(args)
    robot, traj = inputs.robot, inputs.trajectory
    parts = _parts(args, robot.joint_names)
    if parts is None and args.battery_Wh is not None:
        raise StudioError("--battery-Wh needs servo parts: a --servo file that names servos")
    mass_note, sized = None, None
    if args.servo_masses is not None:
        if parts is None:
            raise StudioError("--servo-masses needs servo parts: a --servo file that names servos")
        robot, mass_note = _swap_masses(args, robot, parts)
        inputs = dataclasses.replace(inputs, robot=robot, feedforward=None)
    law = None
    if parts is not None:
        from app.core.simulation.part_law import part_servo_law

        servo, law = parts.servo_model(), part_servo_law(parts)
    elif args.servo is not None:
        servo = read_servo_toml(args.servo, robot)
    else:
        servo = inputs.servo if inputs.servo is not None else sized_servos(robot)
        if inputs.servo is None:
            from app.core.servo.scaling import scaled_ideal_servo

            sized = scaled_ideal_servo(robot).text()
    from_project = args.cmd is None and args.preset is None and args.compensation is None
    if from_project and inputs.compensation is None:
        raise StudioError(
            "give --cmd, --compensation or --preset, or a project with compensation coefficients"
        )
    options = SimOptions(friction=args.friction, hulls=args.hulls, command_hold=args.hold)
    if args.drive_torque and (args.cmd is not None or args.preset == "plan"):
        raise StudioError("--drive-torque goes with a compensation (--preset, --compensation)")

    # a project's compensation on the torque its studio compensated
    drive = args.drive_torque or (from_project and inputs.compensation_torque == "drive")

    @functools.cache
    def planned_tau() -> np.ndarray:  # the whole-body QP of a walk: once per command
        return _torques(args, robot, traj, inputs)

    def load() -> np.ndarray:
        from app.core.simulation.drive import plan_drive_torque_Nm

        tau = planned_tau()
        return plan_drive_torque_Nm(robot, traj, tau, servo, law, options) if drive else tau

    commands, label = _commands(args, robot, traj, inputs, parts, from_project, load, drive)
    if args.cmd is None:  # computed commands: clipped to the limits as a servo clips its goal
        commands, clip_note = clipped_commands(robot, traj.t, commands)
    stand = _stand_check(robot, traj, servo)
    balance = _balance(args)
    results = simulate_commands(robot, traj, commands, servo, options, law=law, balance=balance)
    unaided = None  # with the feedback: the same runs without it, for the verdict beside
    if balance is not None:
        unaided = simulate_commands(robot, traj, commands, servo, options, law=law)
    if args.cmd is None:
        results = with_note(results, clip_note)
    main = results[label]
    figures = None
    if parts is not None and main.energy is not None:
        figures = _energy_figures(args, robot, traj, inputs, parts, main)
    ideal = None
    if law is None:  # the ideal servo: electrical energy from the stated default motor
        ideal = ideal_energy(robot, traj, servo, options, main, planned_tau)
    if args.out is not None:
        write_simulation_csv(args.out, main)
    if args.json:
        return print_report(
            _add_unaided(
                _json_report(
                    args, robot, traj, results, main, parts, figures, stand, mass_note, sized
                ),
                unaided,
                label,
            )
            | ({} if ideal is None else {"ideal_servo_energy": ideal})
        )
    _print_report(args, robot, traj, results, main, figures, stand, mass_note, sized)
    if unaided is not None:
        print(_pair_lines(robot, traj, results, unaided))
    if ideal is not None and ideal["sr_planned"] is not None:
        print(ideal_line(ideal))
    return 0


def _balance(args: argparse.Namespace):
    """The balance feedback's gains (--balance-feedback, --balance-gain), or None: off."""
    from app.core.simulation.balance_feedback import gains_from_pairs

    if not args.balance_feedback:
        if args.balance_gain:
            raise StudioError("--balance-gain goes with --balance-feedback")
        return None
    return gains_from_pairs(args.balance_gain)


def _add_unaided(report: dict, unaided: dict | None, label: str) -> dict:
    """With the balance feedback, each run's verdict without it: `verdict_without_feedback`
    of the main run and of the baseline (in its dict); the report as it was without it."""
    if unaided is not None:
        report["verdict_without_feedback"] = unaided[label].verdict()
        if "baseline" in report:
            report["baseline"]["verdict_without_feedback"] = unaided[
                "without compensation"
            ].verdict()
    return report


def _pair_lines(robot, traj, results: dict, unaided: dict) -> str:
    """Per run: "with balance feedback: stays up · without: falls at 0.14 s (base)"."""
    from app.core.simulation.balance_feedback import LABEL
    from app.core.simulation.verdicts import pair_text

    lines = []
    for label, result in results.items():
        aided, alone = result.outcome, unaided[label].outcome
        if aided is not None and alone is not None:
            pair = pair_text(aided, alone, f"with {LABEL}")
            lines.append(f"{robot.name}, {traj.name} {label}: {pair}")
    return "\n".join(lines)


def _json_report(
    args: argparse.Namespace, robot, traj, results, main, parts, figures, stand, mass_note, sized
) -> dict:
    """What --json prints: the main run's summary (with `balance_feedback`: on, its gains),
    the baseline's, energy and notes."""
    report = {"robot": robot.name, "n_samples": traj.n_samples, **main.summary()}
    report["out"] = written(args.out)
    report["stand_check"] = stand
    report["servo_default"] = sized
    if len(results) > 1:
        report["baseline"] = results["without compensation"].summary()
    if parts is not None and main.energy is not None:
        report["servos"] = parts.to_json()
        report["energy"] = main.energy.to_json()
    if figures is not None:
        report["energy_figures"] = figures.to_json()
    if mass_note is not None:
        report["servo_masses"] = mass_note
    return report


def _print_report(
    args: argparse.Namespace, robot, traj, results, main, figures, stand, mass_note, sized
) -> None:
    """One line per run, energy and figures, and the notes (on stderr)."""
    for result in results.values():
        s = result.summary()
        print(
            f"{robot.name}, {traj.name} {result.label}: {result.verdict()}; max |roll| "
            f"{s['max_abs_roll_deg']:.2f}°, max |pitch| {s['max_abs_pitch_deg']:.2f}°, rms joint "
            f"error {s['rms_joint_error_deg']:.2f}°, {s['real_time_factor']:.1f}× real time"
            + (output_target(args.out) if result is main else "")
        )
    if main.balance_feedback is not None:
        from app.core.simulation.balance_feedback import balance_line

        print(balance_line(main.balance_feedback, main.balance_offsets_rad))
    if main.energy is not None:
        e = main.energy
        print(
            f"energy over {e.duration_s:.2f} s: {e.electrical_J.sum():.1f} J electrical, "
            f"{e.joule_J.sum():.1f} J heat (I²R); peak current {e.peak_current_A.max():.2f} A on one "
            "servo"
        )
    if figures is not None:
        print(figures_line(figures))
    if mass_note is not None:
        print(f"note: {mass_note}", file=sys.stderr)
    if sized is not None:
        print(f"note: {sized}", file=sys.stderr)
    for note in main.notes:
        print(f"note: {note}", file=sys.stderr)
    if stand is not None and not stand.startswith("stands"):
        print(f"note: {robot.name} {stand}", file=sys.stderr)


def _energy_figures(args, robot, traj, inputs: MotionInputs, parts, result):
    """Currents, SR (electrical beside planned) and the battery figure of a run on parts."""
    import numpy as np

    from app.core.simulation.battery import run_energy_figures

    vin = np.array([p.firmware.vin_V for p in parts.parts])
    return run_energy_figures(
        result, robot, traj, vin, lambda: _torques(args, robot, traj, inputs), args.battery_Wh
    )


def _swap_masses(args: argparse.Namespace, robot, parts):
    """The robot with each part's mass in place of the counted servo's, and the note."""
    from app.core.servo.catalogue import load_catalogue, read_user_servos, with_user_servos
    from app.core.servo.masses import with_servo_masses

    counted = {}
    if args.servo_masses != "none":
        catalogue = load_catalogue()
        for path in args.servos:
            catalogue = with_user_servos(catalogue, read_user_servos(path))
        record = catalogue.get(args.servo_masses)
        if record is None:
            raise StudioError(
                f"--servo-masses {args.servo_masses!r}: give none or a catalogue key "
                f"({', '.join(sorted(catalogue))})"
            )
        counted = {p.joint: record.mass_kg for p in parts.parts}
    new = {p.joint: p.mass_kg for p in parts.parts}
    robot, swap = with_servo_masses(robot, new, counted)
    return robot, swap.note()
