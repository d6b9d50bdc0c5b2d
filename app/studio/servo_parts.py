"""What the simulation takes from the servo parts in the state (`StudioState.work.parts`): the
servo law to run (`simulation_law`, the CLI's `part_law` functions) and the energy line of a
run on parts (`energy_line`), and what the Servos folder says of a user's servo file
(`added_text`) and does when one is removed (`without_file`, `removed_text`), and the sizing's
text (`sizing_text`). Not a session: the simulation and servos sessions call these hooks.
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

from app.core.dynamics.wbc import FeedForward
from app.core.motions.trajectory import Trajectory
from app.core.robot.model import RobotModel
from app.core.servo.catalogue import (
    DATASHEET_FIT,
    ServoRecord,
    load_catalogue,
    why_not_simulated,
)
from app.core.servo.choice import (
    JointServo,
    ServoChoice,
    choice_parts,
    offered_catalogue,
    runnable,
)
from app.core.servo.model import ServoModel
from app.core.servo.parts import ServoPartsError
from app.core.servo.sizing import JointSizing, Sizing
from app.core.servo.sizing_totals import totals
from app.core.servo.sizing_work import Work
from app.core.servo.user_files import UserServoFile, records
from app.core.simulation.battery import run_energy_figures
from app.core.simulation.result import SimulationResult
from app.core.simulation.servo_law import ServoLaw


@functools.cache
def catalogue() -> dict[str, ServoRecord]:
    """The built-in servo catalogue (robots/servos), read once."""
    return load_catalogue()


def simulation_law(
    robot: RobotModel, servo: ServoModel, choice: ServoChoice | None
) -> ServoLaw | None:
    """The servo law for a simulation of `robot`: the parts on their joints, the virtual
    servos elsewhere; None when every joint is ideal. Raises StudioError (ServoPartsError)
    naming a setting that cannot be simulated."""
    from app.core.simulation.part_law import law_with_parts

    if choice is None:
        return None
    parts = choice_parts(choice, robot.joint_names, catalogue())
    return law_with_parts(robot, servo, parts)


def energy_line(
    result: SimulationResult,
    robot: RobotModel,
    trajectory: Trajectory,
    choice: ServoChoice | None,
    torques: FeedForward | None,
) -> str:
    """The run's electrical energy, currents, specific resistance (electrical beside planned
    work) and battery minutes, as `biped-studio simulate` gives them; "" for a run without
    parts."""
    energy = result.energy
    if energy is None or choice is None or energy.duration_s <= 0.0:
        return ""
    vin = np.ones(len(robot.joint_names))  # ideal joints draw nothing: any voltage will do
    offered = offered_catalogue(choice, catalogue())
    for name in choice.chosen:
        joint = choice.joint(name)
        record = offered.get(joint.servo)
        firmware = record.firmware if record is not None else None
        rated = record.rated if record is not None else None  # no firmware: its rated voltage
        vin[robot.joint_names.index(name)] = joint.vin_V or (
            firmware.vin_V if firmware is not None else rated.supply_voltage_V if rated else 1.0
        )
    f = run_energy_figures(
        result,
        robot,
        trajectory,
        vin,
        lambda: None if torques is None else np.nan_to_num(torques.tau_Nm),
        choice.battery_Wh,
    )
    sr = (
        "in place: no specific resistance"
        if f.sr_electrical is None
        else f"SR {f.sr_electrical:.3g} electrical"
        + ("" if f.sr_planned is None else f", {f.sr_planned:.3g} planned work")
    )
    line = (
        f"**Energy** with compensation ({len(choice.chosen)} joint(s) on servo parts, "
        f"{f.duration_s:.1f} s): {f.electrical_J:.1f} J electrical, {f.joule_J:.1f} J heat; "
        f"average {f.average_power_W:.1f} W; {f.labelled_currents()}; {sr}"
    )
    if f.battery_minutes is not None:
        line += f"; a {f.pack_Wh:g} Wh pack lasts **{f.battery_minutes:.0f} min** of this motion"
    return line


def added_text(file: UserServoFile, offered: dict[str, ServoRecord]) -> str:
    """What the Servos folder says of a user's file just added (markdown): its servos, and
    those the simulation cannot run, with why."""
    found = records(file)
    runs = runnable({r.key: r for r in found})
    lines = [
        f"Added {len(found)} servo(s) from **{file.name}** "
        f"({len(offered)} in the catalogue now): "
        + ", ".join(f"{r.key} ({r.maker} {r.model})" for r in found)
    ]
    kept_out = [r for r in found if r.key not in runs]
    if kept_out:
        lines.append(
            f"⚠️ not offered in *Servo*: {', '.join(r.key for r in kept_out)}: "
            + why_not_simulated(kept_out[0])
        )
    derived = [r.key for r in found if r.key in runs and (f := r.fit("m1")) and f.derived]
    if derived:
        lines.append(f"{', '.join(derived)}: {DATASHEET_FIT}")
    return "  \n".join(lines)


def not_offered_text(records: dict[str, ServoRecord]) -> str:
    """The catalogue's servos the Servos folder cannot offer, and why (markdown)."""
    out = sorted(key for key, record in records.items() if why_not_simulated(record))
    if not out:
        return ""
    return (
        f"Not offered (datasheet only: {', '.join(out)}): "
        + why_not_simulated(records[out[0]])
        + " (`biped-studio servos`)."
    )


def users_of_files(choice: ServoChoice, besides: list[str]) -> list[str]:
    """The joints (not in `besides`) on a servo of the choice's user files: when a file is
    replaced their part may have changed under the same key."""
    keys = {record.key for file in choice.user_servos for record in records(file)}
    return [
        name
        for name, joint in zip(choice.joint_names, choice.joints, strict=True)
        if joint.servo in keys and name not in besides
    ]


def without_file(choice: ServoChoice, name: str) -> tuple[ServoChoice, list[str]]:
    """`choice` without the user's servo file `name`, every joint on one of its servos put
    back on the ideal servo, and those joints; ServoPartsError when no file has that name."""
    file = next((f for f in choice.user_servos if f.name == name), None)
    if file is None:
        kept = ", ".join(f.name for f in choice.user_servos) or "none"
        raise ServoPartsError(f"no servo file named {name!r} is kept (kept: {kept})")
    keys = {record.key for record in records(file)}
    reset = [n for n, j in zip(choice.joint_names, choice.joints, strict=True) if j.servo in keys]
    return (
        dataclasses.replace(
            choice,
            user_servos=tuple(f for f in choice.user_servos if f.name != name),
            joints=tuple(JointServo() if j.servo in keys else j for j in choice.joints),
        ),
        reset,
    )


def removed_text(name: str, keys: list[str], reset: list[str]) -> str:
    """What the Servos folder says of a user's file just removed (markdown)."""
    text = f"Removed **{name}** ({', '.join(keys)})"
    if not reset:
        return text + "; no joint was on its servos. *Undo* puts it back."
    return (
        text + f"; {len(reset)} joint(s) were on its servos and are back on the **ideal servo**: "
        f"{', '.join(reset)}. *Undo* puts the file and their servos back."
    )


def _kp_text(joint: JointSizing) -> str:
    """ ", kp 95 (sag 1.0°)" of the servo chosen (a part without a kp law: its stated
    stiffness), "" where its stiffness was not checked."""
    stiffness = None if joint.choice is None else joint.check(joint.choice).stiffness
    if stiffness is not None and stiffness.stated and stiffness.sag_deg is not None:
        k = stiffness.stated_Nm_per_rad
        return f", stiffness K {k:g} N·m/rad stated (no kp law; sag {stiffness.sag_deg:.2g}°)"
    if stiffness is None or stiffness.kp is None or stiffness.sag_deg is None:
        return ""
    on = "" if stiffness.fit == "m1" else f" on {stiffness.fit}"
    return f", kp {stiffness.kp:g}{on} (sag {stiffness.sag_deg:.2g}°)"


def _bounds_text(sizing: Sizing) -> str:
    """ ", stand margin 0.5, sag ≤ 2°" of a sizing that chose kp ("" where it did not)."""
    bounds = sizing.stiffness or {}
    if "stand_margin" not in bounds:
        return ""
    return f", stand margin {bounds['stand_margin']:g}, sag ≤ {bounds['max_sag_deg']:g}°"


def sizing_text(
    sizing: Sizing, works: dict[str, Work], records: dict[str, ServoRecord], total: int
) -> str:
    """The per-joint choice with its margins, the joints no servo holds, and what the chosen
    servos add up to (markdown); `records`: the servos sized over."""
    held = len(sizing.joints) - len(sizing.unsized)
    lines = [
        f"**Sized** against {', '.join(works)} over {len(records)} servos the simulation can run "
        f"(of {total} in the catalogue), margin {sizing.margin:.0%}{_bounds_text(sizing)}: "
        f"{held} of {len(sizing.joints)} joints"
    ]
    for joint in sizing.joints:
        if joint.choice is not None:
            c = joint.check(joint.choice)
            lines.append(
                f"{joint.joint}: **{c.servo}**, peak margin {c.peak_margin:+.0%}, RMS "
                f"{c.rms_torque_Nm:.3g} of {c.continuous_torque_Nm:.3g} N·m" + _kp_text(joint)
            )
        else:
            best = max(joint.checks, key=lambda c: min(c.peak_margin, c.thermal_margin))
            lines.append(
                f"⚠️ {joint.joint}: **no servo holds it** (left on the ideal servo); closest "
                f"{best.servo}: " + "; ".join(best.violations())
            )
    lines.append(f"**Total**: {totals(sizing, records).line()}")
    lines += [f"note: {note}" for note in sizing.notes]
    return "  \n".join(lines)
