"""`servos`: the servo catalogue (robots/servos), with the user's own servos (--servos FILE)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from app.core.papers import TYPICAL_COMPLIANCE_DEG_PER_NM


def add_parser(sub) -> None:
    servos = sub.add_parser("servos")
    servos.add_argument(
        "--servos",
        action="append",
        default=[],
        type=Path,
        metavar="FILE",
        help="a TOML file of your own servos, the catalogue's fields (repeatable)",
    )
    servos.add_argument("--json", action="store_true")


def run(args: argparse.Namespace) -> int:
    from app.core.servo.catalogue import (
        DATASHEET_FIT,
        NO_KP_LAW,
        RATED_FIT,
        identified_names,
        load_catalogue,
        read_user_servos,
        why_not_simulated,
        with_user_servos,
    )

    records = load_catalogue()
    for path in args.servos:
        records = with_user_servos(records, read_user_servos(path))
    used = {r.identified for r in records.values() if r.identified}
    only_identified = [name for name in identified_names() if name not in used]
    if args.json:
        print(
            json.dumps(
                {
                    "servos": [r.to_json() for r in records.values()],
                    "identified_only": only_identified,
                    "paper_compliance_deg_per_Nm": TYPICAL_COMPLIANCE_DEG_PER_NM,
                },
                indent=2,
            )
        )
        return 0
    from app.core.servo.motor_law import compliance_deg_per_Nm, stiffness_Nm_per_rad

    print(
        f"{'key':13s} {'maker / model':32s} {'V':>5s} {'stall':>6s} {'speed':>5s} {'mass':>6s} "
        f"{'gear':>6s} {'play':>5s} {'cont.':>5s} {'price':>11s} {'K m1 / m6':>11s} "
        f"{'1/K m1 / m6':>13s}  simulated as"
    )
    print(
        f"{'':13s} {'':32s} {'':>5s} {'N·m':>6s} {'rpm':>5s} {'g':>6s} {'':>6s} {'°':>5s} "
        f"{'N·m':>5s} {'':>11s} {'N·m/rad':>11s} {'°/(N·m)':>13s}"
    )
    for record in records.values():
        stiffness, compliance = [], []
        for name in ("m1", "m6"):
            law = record.law(name)
            stiffness.append("-" if law is None else f"{stiffness_Nm_per_rad(*law):.1f}")
            compliance.append("-" if law is None else f"{compliance_deg_per_Nm(*law):.2f}")
        if not record.fits:
            stiffness = compliance = ["-"]
        if not record.kp_law:
            stiffness = compliance = ["stated"]
        stall = "-" if record.stall_torque_Nm is None else f"{record.stall_torque_Nm:6.2f}"
        play = f"{record.backlash_deg:g}" if record.backlash_deg is not None else "-"
        cont = record.continuous_torque_Nm
        rated = "-" if cont is None else f"{cont:.2f}"
        price = "-" if record.price is None else f"{record.price:g} {record.price_currency}"
        name = f"{record.maker} {record.model}"[:32]
        print(
            f"{record.key:13s} {name:32s} {record.supply_voltage_V:5.1f} "
            f"{stall:>6s} {record.no_load_speed_rpm:5.0f} "
            f"{record.mass_kg * 1000:6.1f} {record.gear_ratio:6.1f} {play:>5s} {rated:>5s} "
            f"{price:>11s} "
            f"{' / '.join(stiffness):>11s} {' / '.join(compliance):>13s}  {simulated_as(record)}"
        )
    print(
        "K and 1/K: the firmware P loop's stiffness kt·vin·error_gain·kp/R with BAM's firmware "
        "constants and its m1 or m6 fit (the simulation's parts use m1 unless friction_model = "
        f'"m6"); the spring paper\'s k: {TYPICAL_COMPLIANCE_DEG_PER_NM:g} °/(N·m); sources: --json'
    )
    print(
        "cont. (continuous torque) and price: as the maker publishes them, '-' where it does "
        "not (sizing then assumes a fraction of stall torque and cannot size by price)"
    )
    derived = [
        r.key for r in records.values() if (f := r.fit("m1")) is not None and f.derived and r.kp_law
    ]
    if derived:
        print(f"DC model ({', '.join(derived)}): {DATASHEET_FIT}")
    by_point = [r for r in records.values() if r.rated is not None]
    if by_point:
        print(
            f"rated by a continuous point ({', '.join(r.key for r in by_point)}; no stall torque "
            f"published, '-'): {RATED_FIT}; "
            + "; ".join(
                f"{r.key}: kt {p.kt_Nm_per_A:.3g} N·m/A, R {p.R_ohm:.3g} Ω, peak "
                f"{p.torque_limit_Nm:.3g} N·m"
                for r in by_point
                if (p := r.rated) is not None
            )
        )
        print(f"K 'stated' ({', '.join(r.key for r in by_point)}): {NO_KP_LAW}")
    cannot = [r for r in records.values() if why_not_simulated(r)]
    if cannot:
        print(
            f"cannot be simulated ({', '.join(r.key for r in cannot)}): "
            + why_not_simulated(cannot[0])
        )
    if only_identified:
        print("identified by BAM, no sourced datasheet record yet: " + ", ".join(only_identified))
    return 0


def simulated_as(record) -> str:
    """The motor model the simulation runs a record with, or "-" where it cannot."""
    fit = record.fit("m1")
    if record.rated is not None and fit is not None:
        return "DC model (continuous point)"
    if record.firmware is None or fit is None:
        return "-"
    if fit.derived:
        return "DC model (datasheet)"
    return "BAM " + "/".join(f.name for f in record.fits) if record.identified else "own m1"
