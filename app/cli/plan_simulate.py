"""`plan --compare --simulate`: both gaits walked N steps, each walk simulated on the robot's
sized ideal servos (`app.core.simulation.walk_sr`), and their SRs from electrical energy set
beside the paper's Table 4 (measured motor energy) as a symmetric / baseline ratio."""

from __future__ import annotations

from app.core.collocation.table4 import simulated_sr_row

WALK_STEPS = 6
"""Steps of each simulated walk when `plan --steps` gives none."""
NAMES = ("symmetric", "baseline")


def simulated_comparison(
    robot, planar, gaits: dict, steps: int, step_width_m: float | None, dt: float, walk=None
) -> dict[str, object]:
    """Both gaits (name → `GaitResult`) walked `steps` steps on `planar` (`walk`: the
    symmetric one when it is built already) and simulated, as JSON: each walk's verdict,
    distance and `ideal_servo_energy`, and the SRs' symmetric / baseline ratio."""
    from app.core.simulation.walk_sr import COMPENSATION, simulate_walk_sr
    from app.core.walking.walk import build_walk

    walks = {
        name: walk
        if name == "symmetric" and walk is not None
        else build_walk(planar, gaits[name], steps=steps, step_width_m=step_width_m, dt=dt)
        for name in NAMES
    }
    runs = {name: simulate_walk_sr(robot, walks[name].trajectory, name) for name in NAMES}
    sr = [runs[name].sr.sr_electrical for name in NAMES]
    sym, base = sr
    row = None if sym is None or base is None else simulated_sr_row(sym, base)
    return {
        "steps": steps,
        "servo": runs["symmetric"].servo,
        "compensation": COMPENSATION,
        "motor": runs["symmetric"].sr.energy.motor,
        "walks": {
            name: {**runs[name].to_json(), "walk_notes": list(walks[name].notes)} for name in NAMES
        },
        "sr_electrical": sr,
        "sr_planned_work": [runs[name].sr.sr_planned for name in NAMES],
        "ratio": None if row is None else row.ours_ratio,
        "paper": [row.paper_symmetric, row.paper_baseline] if row else None,
        "paper_ratio": None if row is None else row.paper_ratio,
    }


def simulated_lines(simulated: dict) -> list[str]:
    """What `plan --compare --simulate` prints of the simulated walks."""
    lines = [
        f"simulated walks ({simulated['steps']} steps each; {simulated['servo']}; "
        f"{simulated['compensation']}; {simulated['motor']}):"
    ]
    for name, walk in simulated["walks"].items():
        ideal = walk["ideal_servo_energy"]
        over = (
            f" up to the fall at {ideal['until_s']:.2f} s, over the {ideal['distance_m']:.2f} m "
            "it covered"
            if ideal["fell"]
            else f" over {ideal['distance_m']:.2f} m"
        )
        lines.append(
            f"  {name}: {walk['verdict']}; {ideal['total_electrical_J']:.1f} J electrical"
            f"{over}: "
            + (
                "no electrical SR (under 0.1 m)"
                if ideal["sr_electrical"] is None
                else f"SR {ideal['sr_electrical']:.3g} electrical"
            )
            + f", {_sr(ideal['sr_planned'])} planned work"
        )
    if simulated["ratio"] is None:
        lines.append(
            "SR electrical (simulated walks): no ratio, a walk covered under 0.1 m before it fell"
        )
    else:
        lines.append(
            f"SR electrical (simulated walks): symmetric / baseline {simulated['ratio']:.3f} "
            f"(ours), {simulated['paper_ratio']:.3f} (paper, Table 4: measured motor energy)"
        )
    return lines


def _sr(value: float | None) -> str:
    return "-" if value is None else f"{value:.3g}"
