"""What the solver worker process runs for the gait planner (imported only in the worker)."""

from __future__ import annotations

from typing import Any


def build_gait_problem(structure_key: Any) -> Any:
    """A gait NLP for the robot and structure of `structure_key` (built once per key): a
    GaitProblemKey (robot source, package roots, feet, knots, baseline), or the older
    (knots, baseline) pair, which means dircon_biped."""
    from app.core.collocation.job_key import GaitProblemKey

    if isinstance(structure_key, tuple):
        knots, baseline = structure_key
        structure_key = GaitProblemKey("dircon_biped", knots=knots, baseline=baseline)
    if not isinstance(structure_key, GaitProblemKey):
        raise TypeError(f"not a gait problem key: {structure_key!r}")
    return structure_key.build_problem()
