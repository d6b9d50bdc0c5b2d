"""The symmetric efficient gait planner of Chen et al. 2023 (papers/symmetric-gait-dircon.txt).

Constrained direct collocation (DIRCON) of the planar dircon_biped over one complete gait in
three modes (LSP part, RSP, LSP part) with virtual knots at the touch-downs, the foothold slack
constraint (eq. 5), equal support durations, joint-state exchange and periodicity (eq. 6), and
the cost of eq. 7. `baseline=True` gives the "original DIRCON" counterpart of section 5.3.

    problem = GaitProblem(knots=38)              # builds the NLP once (about 3 s)
    result = problem.solve(GaitSettings())       # the paper's case
    result = problem.solve(dataclasses.replace(settings, K0=5.0))   # warm re-solve
    trajectory = to_trajectory(robot, result)    # 100 Hz on the full robot

The modules: planar_model (the x-z rigid-body model), transcription (layout, collocation),
gait_problem (the NLP), nlp (SX + IPOPT), guess (cold start), result, sampling.
"""

from __future__ import annotations

from app.core.collocation.gait_problem import GaitProblem
from app.core.collocation.nlp import IterationCallback
from app.core.collocation.planar_model import PlanarModel, PlanarModelError
from app.core.collocation.result import GaitResult
from app.core.collocation.sampling import GaitSamples, positive_work, sample_gait, to_trajectory
from app.core.collocation.settings import GaitSettings, GaitSettingsError, read_settings_toml
from app.core.robot.model import RobotModel


class GaitPlanner:
    """One GaitProblem per structure (knots, baseline), built on first use and kept."""

    def __init__(self, robot: RobotModel | PlanarModel | None = None) -> None:
        if robot is None:
            from app.core.robot.loading import load_robot

            robot = load_robot("dircon_biped")
        self.model = robot if isinstance(robot, PlanarModel) else PlanarModel(robot)
        self.problems: dict[tuple[int, bool], GaitProblem] = {}

    def problem(self, settings: GaitSettings) -> GaitProblem:
        """The problem for the settings' structure (built now if new); refuses bad settings."""
        settings.validate()
        if settings.structure not in self.problems:
            self.problems[settings.structure] = GaitProblem(
                self.model, settings.knots, settings.baseline
            )
        return self.problems[settings.structure]

    def solve(
        self, settings: GaitSettings, iteration_callback: IterationCallback | None = None
    ) -> GaitResult:
        """Solve, warm-started from the last good gait of the same structure; never raises for
        bad settings (the result says what was wrong)."""
        try:
            problem = self.problem(settings)
        except GaitSettingsError as error:
            return GaitResult.refused(settings, f"invalid settings: {error}")
        return problem.solve(settings, iteration_callback=iteration_callback)


__all__ = [
    "GaitPlanner",
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
