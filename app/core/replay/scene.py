"""What a replay shows, frame by frame: the robot, the ghosts that are shown, the traces, the
camera and a title card. Plain arrays; drawing them is app/replay_recorder.py's job."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping

import numpy as np

from app.core.errors import StudioError
from app.core.motions.paths import task_space_paths
from app.core.motions.trajectory import Trajectory
from app.core.robot.model import RobotModel
from app.core.servo.model import Prediction, command_configuration

DEFAULT_FRAME_RATE_HZ = 30.0
"""Frames per second of a replay: smooth to the eye, 3× fewer messages than a 100 Hz plan."""
MAX_FRAME_RATE_HZ = 60.0
MAX_FRAMES = 60 * 60 * 10
"""At most ten minutes at 60 Hz: a bigger replay is refused before anything is drawn."""
PREDICTED_GHOSTS = ("planned", "command", "without", "with")
"""The ghosts a prediction gives (app.views.ghosts_view.GHOSTS names)."""


class ReplayError(StudioError):
    """A replay that cannot be made or opened: what was wrong and what to do."""


@dataclasses.dataclass(frozen=True, eq=False)
class ReplayScene:
    """A motion resampled for playback, with everything drawn beside the robot."""

    title: str
    """Title card, plain text lines: robot, motion, key parameters, verdicts."""
    frame_dt_s: float
    """Time between frames [s]."""
    q_robot: np.ndarray
    """The robot, shape (F, nq), pinocchio layout."""
    ghosts: dict[str, np.ndarray]
    """Ghost name (app.views.ghosts_view.GHOSTS) -> configurations, shape (F, nq)."""
    paths: dict[str, np.ndarray]
    """Trace name -> world points [m], shape (P, 3); empty when traces are hidden."""
    camera_position_m: tuple[float, float, float]
    camera_look_at_m: tuple[float, float, float]
    title_position_m: tuple[float, float, float]
    """Where the title card hangs: above the robot's start, beside it."""

    @property
    def n_frames(self) -> int:
        return int(self.q_robot.shape[0])

    @property
    def duration_s(self) -> float:
        return (self.n_frames - 1) * self.frame_dt_s


def check_frame_rate(frame_rate_hz: float) -> None:
    if not (math.isfinite(frame_rate_hz) and 0.0 < frame_rate_hz <= MAX_FRAME_RATE_HZ):
        raise ReplayError(
            f"frame rate {frame_rate_hz!r} Hz is outside (0, {MAX_FRAME_RATE_HZ:g}] Hz"
        )


def frame_samples(trajectory: Trajectory, frame_rate_hz: float) -> np.ndarray:
    """Sample index shown at each frame: frames every 1/rate s from 0 to the motion's end
    (the last sample always included)."""
    check_frame_rate(frame_rate_hz)
    n = math.floor(trajectory.duration * frame_rate_hz + 1e-9) + 1
    if n > MAX_FRAMES:
        raise ReplayError(
            f"{trajectory.duration:.0f} s at {frame_rate_hz:g} Hz is {n} frames; at most "
            f"{MAX_FRAMES} fit in a replay (lower the frame rate)"
        )
    times = np.arange(n) / frame_rate_hz
    k = np.array([trajectory.index_at(float(t)) for t in times], dtype=int)
    if k[-1] != trajectory.n_samples - 1:
        k = np.append(k, trajectory.n_samples - 1)
    return k


def replay_scene(
    robot: RobotModel,
    trajectory: Trajectory,
    title: str,
    prediction: Prediction | None = None,
    ghosts: tuple[str, ...] = PREDICTED_GHOSTS,
    extra_ghosts: Mapping[str, np.ndarray] | None = None,
    traces: bool = True,
    frame_rate_hz: float = DEFAULT_FRAME_RATE_HZ,
) -> ReplayScene:
    """The replay of `trajectory`: the robot follows the plan; the named `ghosts` come from
    `prediction` (planned, command, without, with) or `extra_ghosts` (name -> (T, nq) per
    sample, e.g. simulated runs); traces are the feet's and CoM's paths."""
    if trajectory.joint_names != robot.joint_names:
        raise ReplayError(f"motion {trajectory.name!r} is not for robot {robot.name!r}")
    k = frame_samples(trajectory, frame_rate_hz)
    extra = dict(extra_ghosts or {})
    out: dict[str, np.ndarray] = {}
    for name in ghosts:
        if name in extra:
            q = np.asarray(extra[name], dtype=float)
            if q.shape != trajectory.q.shape:
                raise ReplayError(f"ghost {name!r} has shape {q.shape}, not {trajectory.q.shape}")
            out[name] = q[k]
        elif prediction is not None and name in PREDICTED_GHOSTS:
            out[name] = _predicted(robot, trajectory, prediction, name, k)
        else:
            raise ReplayError(f"ghost {name!r} has no poses (compute the torques first)")
    position, look_at, top = _framing(robot, trajectory.q[0])
    return ReplayScene(
        title=title,
        frame_dt_s=1.0 / frame_rate_hz,
        q_robot=trajectory.q[k].copy(),
        ghosts=out,
        paths=task_space_paths(robot, trajectory) if traces else {},
        camera_position_m=position,
        camera_look_at_m=look_at,
        title_position_m=top,
    )


def _predicted(
    robot: RobotModel, trajectory: Trajectory, prediction: Prediction, name: str, k: np.ndarray
) -> np.ndarray:
    if name == "planned":
        return trajectory.q[k].copy()
    if name == "without":
        return prediction.q_world_uncompensated[k].copy()
    if name == "with":
        return prediction.q_world_compensated[k].copy()
    return np.stack([command_configuration(robot, trajectory, prediction, int(i)) for i in k])


def _framing(
    robot: RobotModel, q: np.ndarray
) -> tuple[tuple[float, float, float], tuple[float, float, float], tuple[float, float, float]]:
    """Camera (position, look-at) showing the whole robot at q, like the studio's framing,
    and a point above and behind the robot for the title card."""
    lower, upper = robot.bounds_m(q, robot.model.createData())
    height = max(float(upper[2] - min(float(lower[2]), 0.0)), 0.3)
    cx, cy = float(0.5 * (lower[0] + upper[0])), float(0.5 * (lower[1] + upper[1]))
    look_at = (cx, cy, 0.45 * height)
    position = (cx + 1.3 * height, cy + 0.95 * height, 0.8 * height)
    top = (cx, cy + 0.5 * height, 1.25 * height)
    return position, look_at, top


def title_card(
    robot: str,
    motion: str,
    duration_s: float,
    parameters: Mapping[str, str] | None = None,
    verdicts: tuple[str, ...] = (),
) -> str:
    """The title card's text: one fact per line, markdown emphasis dropped."""
    lines = [f"{robot} — {motion} ({duration_s:.1f} s)"]
    if parameters:
        lines.append(", ".join(f"{name} = {value}" for name, value in parameters.items()))
    lines.extend(verdict.replace("**", "").replace("⚠️", "!").strip() for verdict in verdicts)
    return "\n".join(line for line in lines if line)


@dataclasses.dataclass(frozen=True, eq=False)
class ReplayLayers:
    """What the studio shows beside the robot, to be recorded as shown."""

    prediction: Prediction | None
    """The quick prediction with and without compensation, if the torques are computed."""
    ghosts: tuple[str, ...]
    """Ghosts shown (their checkbox on, and poses to show)."""
    extra_ghosts: dict[str, np.ndarray]
    """Ghosts not from the prediction (simulated runs): name -> (T, nq) per motion sample."""
    traces: bool
    parameters: dict[str, str]
    """Key parameters for the title card."""
    verdicts: tuple[str, ...]
    """Verdict lines for the title card."""
