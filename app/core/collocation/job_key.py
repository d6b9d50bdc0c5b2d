"""What a solver worker needs to rebuild a gait NLP in another process: the robot's source,
its package roots and feet override, and the NLP's structure (knots, baseline).

Hashable and picklable (strings, ints, bools, tuples), so it can be the structure key of
app.jobs.SolverWorker; `build_problem` is what the worker's factory runs.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from app.core.collocation.gait_problem import GaitProblem
from app.core.collocation.settings import GaitSettings
from app.core.robot.model import RobotModel


@dataclasses.dataclass(frozen=True)
class GaitProblemKey:
    """Everything that fixes a GaitProblem: rebuilding from it gives the same NLP."""

    robot: str
    """Built-in robot name or URDF path (as given to load_robot)."""
    package_roots: tuple[str, ...] = ()
    """Folders holding package://NAME folders."""
    feet: tuple[str, str] | None = None
    """(left, right) foot links overriding detection, or None."""
    knots: int = 38
    baseline: bool = False

    @classmethod
    def for_robot(
        cls,
        source: str | Path,
        settings: GaitSettings,
        package_roots: tuple[str | Path, ...] = (),
        feet: tuple[str, str] | None = None,
    ) -> GaitProblemKey:
        """The key of `settings`' structure on the robot loaded from `source`."""
        knots, baseline = settings.structure
        return cls(str(source), tuple(str(p) for p in package_roots), feet, knots, baseline)

    def load_robot(self) -> RobotModel:
        from app.core.robot.loading import load_robot

        return load_robot(
            self.robot, package_roots=tuple(Path(p) for p in self.package_roots), feet=self.feet
        )

    def build_problem(self) -> GaitProblem:
        """The NLP (built now: a few seconds)."""
        return GaitProblem(self.load_robot(), knots=self.knots, baseline=self.baseline)
