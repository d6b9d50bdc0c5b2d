"""`simulate`'s energy lines: the electrical energy and SR of a run on the ideal servo (from
the stated default motor), and the currents, SR and battery figure of a run on servo parts."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

__all__ = ["figures_line", "ideal_energy", "ideal_line"]


def ideal_energy(robot, traj, servo, options, main, planned_tau: Callable[[], np.ndarray]) -> dict:
    """The run's electrical energy on the ideal servo from the default motor, its SR beside
    the planned work's (a motion that travels), as JSON (`ideal_energy.run_ideal_sr`)."""
    from app.core.simulation.ideal_energy import run_ideal_sr
    from app.core.simulation.servo_law import robot_servo_law

    return run_ideal_sr(
        main, robot, traj, robot_servo_law(robot, servo), planned_tau, options.timestep_s,
        options.command_hold == "linear",
    ).to_json()  # fmt: skip


def ideal_line(ideal: dict) -> str:
    return (
        f"energy on the ideal servo over {ideal['duration_s']:.2f} s"
        + (" (up to the fall)" if ideal["fell"] else "")
        + ": "
        f"{ideal['total_electrical_J']:.1f} J electrical ({ideal['total_mechanical_J']:.1f} J "
        f"mechanical, {ideal['total_joule_J']:.1f} J I²R); SR {_sr(ideal['sr_electrical'])} "
        f"electrical, {_sr(ideal['sr_planned'])} planned work ({ideal['motor']})"
    )


def figures_line(f) -> str:
    sr = (
        "in place: no SR"
        if f.sr_electrical is None and f.sr_planned is None
        else f"SR {_sr(f.sr_electrical)} electrical, {_sr(f.sr_planned)} planned work"
    )
    line = f"average {f.average_power_W:.1f} W from the supply; {f.labelled_currents()}; {sr}"
    if f.battery_minutes is not None:
        line += f"; a {f.pack_Wh:g} Wh pack lasts {f.battery_minutes:.0f} min of this motion"
    return line


def _sr(value: float | None) -> str:
    return "-" if value is None else f"{value:.3g}"
