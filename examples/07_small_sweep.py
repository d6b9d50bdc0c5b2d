"""07 — A small design sweep: which step length and duration walk most cheaply?

A sweep spec (the same keys as a sweep.toml, see examples/sweep_dircon.toml) names the robot,
the swept parameters and the metrics whose Pareto front we want. `sweep_points` samples it;
`evaluate_point` solves one point's gait. `biped-studio sweep` runs the points on Dask
workers; here they run one after the other in this process, which is the same computation.

    .venv/bin/python examples/07_small_sweep.py
"""

from app.core.sweeps.evaluate import evaluate_point
from app.core.sweeps.results import pareto_indices
from app.core.sweeps.sampling import sweep_points
from app.core.sweeps.spec import SweepSpec

spec = SweepSpec.from_mapping(
    {
        "robot": "dircon_biped",
        "sampling": "grid",  # grid | random | latin
        "gait": {"knots": 12},  # fixed planner settings for every point
        "pareto": {"sr": "min", "max_torque_Nm": "min"},
        "parameter": [
            {"name": "step_length_m", "kind": "gait", "min": 0.15, "max": 0.25, "levels": 2},
            {"name": "H_s", "kind": "gait", "min": 0.65, "max": 0.8, "levels": 2},
        ],
    },
    source="example",
)
points = sweep_points(spec)  # 2 × 2 grid
print(f"{len(points)} points over {', '.join(p.name for p in spec.parameters)}")

results = []
for point in points:
    result = evaluate_point(point)  # never raises on a bad point: solved=False and a reason
    results.append(result)
    values = ", ".join(f"{v:.3f}" for v in result.values)
    if result.solved:
        print(
            f"  #{result.index} ({values}): SR {result.sr:.3f}, max |tau| {result.max_torque_Nm:.1f} N·m"
        )
    else:
        print(f"  #{result.index} ({values}): {result.status} ({result.reason})")

# Points no other point beats on both SR and torque (unsolved points are never on it).
front = pareto_indices(spec, results)
print(f"Pareto front of SR vs max torque: points {front}")
