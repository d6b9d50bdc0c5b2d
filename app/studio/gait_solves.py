"""The gait session's solves: the one under way, the last one ended, the convergence history,
and the problem structures the solver worker holds (its warm starts). No viser: the session
shows what this records."""

from __future__ import annotations

import dataclasses
import itertools
import threading
import time
from pathlib import Path

from app.core.collocation.gait_problem import REFINE_ABOVE_KNOTS
from app.core.collocation.job_key import GaitProblemKey
from app.core.collocation.result import GaitResult
from app.core.collocation.settings import GaitSettings
from app.core.robot.model import RobotModel
from app.studio.gait_text import Solve

History = tuple[list[int], list[float], list[float]]
"""Iteration, objective, constraint violation."""


class GaitSolves:
    """What the solver worker was asked and what it answered, one solve at a time."""

    def __init__(self, package_roots: tuple[Path, ...] = ()) -> None:
        self._package_roots = package_roots
        self._lock = threading.Lock()
        self._ids = itertools.count(1)
        self.running: Solve | None = None
        """The solve under way."""
        self.last: Solve | None = None
        """The last solve that ended, good or not."""
        self.history: History = ([], [], [])
        """Iteration, objective, constraint violation of the solve under way (or the last)."""
        self.stage = 1
        """Stage of the solve under way: 1, or 2 once a refining solve's fine mesh started."""
        self._solved_keys: set[GaitProblemKey] = set()
        """Structures the worker holds a result of (a warm start: no mesh refinement)."""
        self._converged_keys: set[GaitProblemKey] = set()
        """Structures the worker holds a converged gait of (its solves start warm)."""

    def key(self, robot: RobotModel, settings: GaitSettings) -> GaitProblemKey:
        """The problem structure of `settings` on `robot` (what the worker builds once)."""
        feet = (robot.feet[0].link, robot.feet[1].link)
        return GaitProblemKey.for_robot(robot.source, settings, self._package_roots, feet)

    def start(
        self, settings: GaitSettings, robot: RobotModel, kind: str, key: GaitProblemKey
    ) -> tuple[Solve, bool]:
        """A new solve under way, and True; or the solve already under way, and False."""
        refines = settings.knots > REFINE_ABOVE_KNOTS and key not in self._solved_keys
        with self._lock:
            if self.running is not None:
                return self.running, False
            self.running = Solve(
                f"gait-{next(self._ids)}", settings, robot, time.monotonic(), kind=kind,
                refines=refines, warm=key in self._converged_keys, key=key,
            )  # fmt: skip
            self.history = ([], [], [])
            self.stage = 1
            return self.running, True

    def submitted(self, key: GaitProblemKey) -> None:
        """The worker builds `key`'s structure: its next solve starts from this one's result."""
        self._solved_keys.add(key)

    def progress(
        self, job_id: str, iteration: int, objective: float, violation: float
    ) -> tuple[Solve, History] | None:
        """Record an iteration of solve `job_id`: the solve and a copy of its history (None when
        it is not the solve under way)."""
        with self._lock:
            running = self.running
            if running is None or running.job_id != job_id:
                return None
            iterations, objectives, violations = self.history
            if running.refines and iterations and iteration < iterations[-1]:
                self.stage = 2  # the coarse solve ended: the fine mesh's iterations start
                for series in (iterations, objectives, violations):
                    series.clear()
            iterations.append(iteration)
            objectives.append(objective)
            violations.append(violation)
            return running, (list(iterations), list(objectives), list(violations))

    def end(
        self, job_id: str, robot: RobotModel | None, result: GaitResult | None, error: str
    ) -> Solve | None:
        """Solve `job_id` ended (None when it is not the solve under way). Its result is dropped
        when `robot`, the robot loaded now, is not the one it planned for."""
        with self._lock:
            running = self.running
            if running is None or running.job_id != job_id:
                return None
            ended = dataclasses.replace(
                running, result=result, error=error, ended_s=time.monotonic()
            )
            if running.robot is not robot:
                ended = dataclasses.replace(ended, result=None, error="another robot was loaded")
            elif result is not None and result.converged and running.key is not None:
                self._converged_keys.add(running.key)
            self.running, self.last = None, ended
            return ended

    def forget_last(self) -> None:
        with self._lock:
            self.last = None

    def forget_structures(self) -> None:
        """The worker restarted (a crash, a cancel, closing): it holds no structure."""
        self._converged_keys.clear()
        self._solved_keys.clear()
