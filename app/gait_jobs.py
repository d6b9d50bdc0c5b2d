"""What the solver worker process runs for the gait planner (imported only in the worker)."""

from __future__ import annotations

from typing import Any


def build_gait_problem(structure_key: tuple[int, bool]) -> Any:
    """A gait NLP for dircon_biped with `knots` knots, symmetric or baseline (built once per key)."""
    from app.core.collocation.dircon import GaitProblem
    from app.core.robot.loading import load_robot

    knots, baseline = structure_key
    return GaitProblem(load_robot("dircon_biped"), knots=knots, baseline=baseline)
