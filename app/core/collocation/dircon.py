"""The symmetric efficient gait planner of Chen et al. 2023 (papers/symmetric-gait-dircon.txt).

Constrained direct collocation (DIRCON) of the planar dircon_biped over one complete gait in
three modes (LSP part, RSP, LSP part) with virtual knots at the touch-downs, the foothold slack
constraint (eq. 5), equal support durations, joint-state exchange and periodicity (eq. 6), and
the cost of eq. 7. `baseline=True` gives the "original DIRCON" counterpart of section 5.3.

    problem = GaitProblem(knots=38)              # builds the NLP once (about 1.5 s)
    result = problem.solve(GaitSettings())       # the paper's case
    result = problem.solve(dataclasses.replace(settings, K0=5.0))   # warm re-solve
    trajectory = to_trajectory(robot, result)    # 100 Hz on the full robot

The modules: planar_model (the x-z rigid-body model), transcription (layout, collocation),
gait_nlp (the NLP's constraints and cost), gait_bounds (its bounds per solve), gait_problem
(solving it), nlp (SX + IPOPT: nlp_blocks the derivatives, nlp_ipopt the solvers), guess
(cold start), result, sampling.
"""

from __future__ import annotations

from app.core.collocation.gait_problem import GaitProblem
from app.core.collocation.nlp import IterationCallback
from app.core.collocation.planar_model import PlanarModel, PlanarModelError
from app.core.collocation.result import GaitResult
from app.core.collocation.sampling import GaitSamples, positive_work, sample_gait, to_trajectory
from app.core.collocation.settings import GaitSettings, GaitSettingsError, read_settings_toml

__all__ = [
    "GaitProblem",
    "GaitResult",
    "GaitSamples",
    "GaitSettings",
    "GaitSettingsError",
    "IterationCallback",
    "PlanarModel",
    "PlanarModelError",
    "positive_work",
    "read_settings_toml",
    "sample_gait",
    "to_trajectory",
]
