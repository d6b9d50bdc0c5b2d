"""The studio's work as a project keeps it: marks (references to the current values) and the
Project they make.

The work lives in the shared state (robot, pose, motion, playback time, display) and in the
sessions that hold user state (keyframes, torques and coefficients, gaits, the sweep). Each of
those implements `HoldsWork` (`snapshot()` / `restore()`); the project session hands them here
and never imports them. Marks hold references, no copies: every edit replaces the value it
edits, so two marks hold the same work when they hold the same objects (`same`).
"""

from __future__ import annotations

import dataclasses
import threading
from collections.abc import Sequence
from pathlib import Path
from typing import Any, Protocol

from app.core.collocation.settings import GaitSettings
from app.core.projects.codec import ProjectError
from app.core.projects.display import ALL_JOINTS, DisplaySettings, plot_choices, same_display
from app.core.projects.project import Project, RobotSource
from app.core.projects.robot_files import robot_source
from app.core.robot.model import RobotModel
from app.studio.state import StudioState

Marks = dict[str, Any]


class HoldsWork(Protocol):
    """A session holding user state that a project keeps."""

    def snapshot(self) -> dict[str, Any]:
        """Its part of a Project: field name → current value (no copies: values are replaced,
        never changed in place, on every edit)."""
        ...

    def restore(self, project: Project) -> None:
        """Show `project`'s part; called after the project's robot and motion are installed."""
        ...


class ProjectWork:
    """The current work: as marks (`marks`), as a Project (`project`), as last `saved`;
    restored by `parts`."""

    def __init__(
        self, state: StudioState, parts: Sequence[HoldsWork], package_roots: tuple[Path, ...]
    ) -> None:
        self._state = state
        self.parts = tuple(parts)
        self._package_roots = package_roots
        self._sources: tuple[RobotModel, RobotSource] | None = None
        """The last robot packed and its source (packing reads the robot's files)."""
        self.lock = threading.Lock()
        """Guards `saved` and file writes (save and autosave may overlap)."""
        self.saved: Marks | None = None
        """The work as last saved to or opened from a file (None: not saved)."""

    @property
    def dirty(self) -> bool:
        """Whether the work differs from the one last saved."""
        return not same(self.saved, self.marks())

    def marks(self) -> Marks:
        """The current work, by reference: compared with `same`, turned into a Project."""
        with self._state.lock:
            marks: Marks = {
                "loaded": self._state.loaded,
                "pose": self._state.pose,
                "motion": self._state.motion,
                "time_s": self._state.time_s,
                "display": self._state.display.settings,
            }
        for part in self.parts:
            marks.update(part.snapshot())
        return marks

    def project(self, marks: Marks | None = None) -> Project:
        """The work (the current one without `marks`) as a Project."""
        marks = self.marks() if marks is None else marks
        loaded, pose, motion = marks["loaded"], marks["pose"], marks["motion"]
        if loaded is None or pose is None:
            raise ProjectError("no robot is loaded: nothing to save")
        fields = {k: v for k, v in marks.items() if k not in ("loaded", "pose", "motion")}
        display: DisplaySettings = fields["display"]
        if display.plot_joints not in plot_choices(loaded.robot.joint_names):
            fields["display"] = dataclasses.replace(display, plot_joints=ALL_JOINTS)
        return Project(
            robot=self._source(loaded.robot),
            q=pose.q,
            stance=pose.stance,
            motion=motion.trajectory if motion is not None else None,
            motion_summary=motion.summary if motion is not None else "",
            **fields,
        )

    def _source(self, robot: RobotModel) -> RobotSource:
        cached = self._sources
        if cached is not None and cached[0] is robot:
            return cached[1]
        source = robot_source(robot, self._package_roots)
        self._sources = (robot, source)
        return source


def same(a: Marks | None, b: Marks) -> bool:
    """Whether two marks hold the same work (the same objects, or equal plain values)."""
    if a is None or a.keys() != b.keys():
        return False
    return all(_same_value(a[key], b[key]) for key in a)


def _same_value(x: object, y: object) -> bool:
    if x is y:
        return True
    if isinstance(x, tuple) and isinstance(y, tuple):
        return len(x) == len(y) and all(_same_value(i, j) for i, j in zip(x, y, strict=True))
    if isinstance(x, DisplaySettings) and isinstance(y, DisplaySettings):
        return same_display(x, y)  # a tab's echo of a restored camera is the same view
    if isinstance(x, float | int | str | bool | GaitSettings):
        return type(x) is type(y) and x == y
    return False


def contents(project: Project) -> str:
    """What a project holds, in a few words: robot, motion, keyframes, results."""
    parts = [project.robot.builtin or project.robot.name]
    if project.motion is not None:
        parts.append(f"motion {project.motion.name} at {project.time_s:.2f} s")
    if project.keyframes:
        parts.append(f"{len(project.keyframes)} keyframe(s)")
    parts += [
        what
        for what, present in (
            ("torques", project.feedforward is not None),
            ("gait", project.gait_symmetric is not None or project.gait_baseline is not None),
            ("simulation", bool(project.simulation)),
        )
        if present
    ]
    return ", ".join(parts)
