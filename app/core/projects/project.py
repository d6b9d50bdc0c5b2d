"""Project: everything a user made in the studio, as one typed value (what a .bstudio holds).

Only the robot's *source* is kept (a built-in name, or the URDF and its meshes packed as an
upload archive, `RobotSource.files`); the robot is loaded again on open, and every stored value
is then checked against it (`check_fits`): a pose, motion, torques or coefficients of another
robot are refused, not installed, and so is a value that robot cannot take (a joint past its
limits, a zero quaternion, a torque of 1e308: app.core.projects.values).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from app.core.collocation.result import GaitResult
from app.core.collocation.settings import GaitSettings
from app.core.dynamics.wbc import FeedForward
from app.core.motions.keyframes import Keyframe
from app.core.motions.trajectory import Trajectory
from app.core.posing.ik import Stance
from app.core.projects.codec import ProjectError
from app.core.projects.display import DisplaySettings, plot_choices
from app.core.robot.model import RobotModel
from app.core.servo.choice import ServoChoice
from app.core.servo.compensation import CompensationParams
from app.core.servo.model import ServoModel
from app.core.simulation.drive import CompensatedTorque
from app.core.simulation.result import SimulationResult
from app.core.sweeps.results import SweepRecord
from app.core.walking.walk import Walk


@dataclasses.dataclass(frozen=True)
class RobotSource:
    """Where the project's robot comes from."""

    name: str
    """The robot's name (from its URDF), to say which robot a project needs."""
    builtin: str = ""
    """A built-in robot's name; "" when the robot's files are embedded."""
    files: bytes = b""
    """The URDF and its meshes as a zip laid out like an upload (app.core.robot.uploads)."""
    urdf_entry: str = ""
    """The URDF's name inside `files`."""
    feet: tuple[str, str] = ("", "")
    """(left, right) foot links the robot was loaded with."""
    notes: tuple[str, ...] = ()
    """What could not be embedded (a mesh outside the robot's folders), said on save."""


@dataclasses.dataclass(frozen=True, eq=False)
class Project:
    """The studio's work. Optional parts are None (or empty) when the user had none."""

    robot: RobotSource
    q: np.ndarray
    """The current pose, pinocchio layout (nq,)."""
    stance: Stance = "both"
    keyframes: tuple[Keyframe, ...] = ()
    motion: Trajectory | None = None
    motion_summary: str = ""
    """The Playback panel's description of the motion (markdown)."""
    time_s: float = 0.0
    """Playback position [s]."""
    feedforward: FeedForward | None = None
    """Torques of `motion`."""
    compensation: CompensationParams | None = None
    servo: ServoModel | None = None
    """The virtual servos' compliance and dead band."""
    servo_parts: ServoChoice | None = None
    """The servo of each joint (ideal, or a catalogue servo and its firmware settings); None
    in files saved before parts were kept (every joint ideal). `compensation` and `servo`
    already hold what follows from it (k = 1/K, the part's dead band)."""
    compensation_torque: CompensatedTorque = "load"
    """The torque `compensation` multiplies: "drive" (τ + D·q̇ + J·q̈ of the simulated servos,
    app.core.simulation.drive) or "load" (τ; files saved before the choice was kept)."""
    gait_settings: GaitSettings | None = None
    """The gait panel's settings."""
    gait_steps: int = 0
    """The gait panel's number of steps to walk (0: unset)."""
    gait_symmetric: GaitResult | None = None
    gait_baseline: GaitResult | None = None
    walk: Walk | None = None
    """The walk of a gait when it is the current motion (its footprints are drawn)."""
    simulation: tuple[SimulationResult, ...] = ()
    """The last good physics runs of `motion` (without, then with compensation)."""
    simulation_stale: bool = False
    """The coefficients or servos changed after `simulation` ran."""
    simulation_wall_s: float | None = None
    """How long the user waited for `simulation` [s]; None in files saved before it was kept."""
    sweep: SweepRecord | None = None
    """The Sweep panel's last sweep (its spec and every point's metrics)."""
    saved_at: str = ""
    """UTC time of the save, ISO 8601."""
    autosave_of: str = ""
    """In an autosave only: the name of the project the work was (its file's stem, an
    upload's name; "" for untitled work), so that a restore keeps calling it that."""
    autosave_path: str = ""
    """In an autosave only: the .bstudio file the work was opened from or saved to ("" when
    none), so that *Save* after a restore writes there again."""
    display: DisplaySettings = dataclasses.field(default_factory=DisplaySettings)
    """How the studio showed the work (camera, toggles, ghosts, plots, playback speed); the
    defaults in files saved before it was kept."""


def check_fits(project: Project, robot: RobotModel) -> None:
    """ProjectError unless every stored value belongs to `robot` (its nq, its joints) and is
    one it can take (app.core.projects.values: joints within limits, unit quaternions, sane
    magnitudes), as a load in the studio would check it."""
    from app.core.projects.values import check_values

    names = robot.joint_names

    def need(ok: bool, message: str) -> None:
        if not ok:
            raise ProjectError(f"the project does not fit {robot.name}: {message}")

    need(
        project.q.shape == (robot.model.nq,),
        f"the pose has {project.q.size} values, not {robot.model.nq}",
    )
    for i, keyframe in enumerate(project.keyframes):
        where = f"keyframes[{i}]"
        for label in ("T_world_left", "T_world_right", "T_world_pelvis"):
            value = getattr(keyframe, label)
            need(value is None or value.shape == (4, 4), f"{where}.{label} is not 4×4")
        need(
            keyframe.com_xy is None or keyframe.com_xy.shape == (2,),
            f"{where}.com_xy is not 2 values",
        )
        need(
            keyframe.q is None or keyframe.q.shape == (robot.model.nq,),
            f"{where}.q has the wrong size",
        )
        need(
            np.isfinite(keyframe.duration_s) and keyframe.duration_s > 0.0,
            f"{where}.duration_s must be positive",
        )
    motion = project.motion
    if motion is not None:
        need(motion.joint_names == names, "the motion's joints differ")
        need(motion.q.shape[1] == robot.model.nq, "the motion's configurations have the wrong size")
        need(
            motion.v.shape[1] == robot.model.nv and motion.a.shape == motion.v.shape,
            "the motion's velocities have the wrong size",
        )
    else:
        need(
            project.feedforward is None and not project.simulation,
            "torques or a simulation without a motion",
        )
    ff = project.feedforward
    if ff is not None and motion is not None:
        need(ff.joint_names == names, "the torques' joints differ")
        need(
            ff.tau_Nm.shape == (motion.n_samples, len(names)),
            "the torques do not match the motion's samples",
        )
        need(len(ff.status) == motion.n_samples, "the torques' status does not match the motion")
    for label, part in (
        ("compensation", project.compensation),
        ("servo", project.servo),
        ("servo_parts", project.servo_parts),
    ):
        need(part is None or part.joint_names == names, f"the {label} joints differ")
    need(
        project.servo_parts is None or len(project.servo_parts.joints) == len(names),
        "the servo_parts do not give one servo per joint",
    )
    need(
        project.simulation_wall_s is None or project.simulation_wall_s >= 0.0,
        f"the simulation's wall time is {project.simulation_wall_s} s",
    )
    for run in project.simulation:
        need(
            motion is not None and run.q.shape == motion.q.shape and run.joint_names == names,
            f"simulation {run.label!r} does not match the motion",
        )
    if project.simulation:
        need(
            project.feedforward is not None
            and project.compensation is not None
            and project.servo is not None,
            "a simulation needs the torques, compensation and servos it was run with",
        )
    need(np.isfinite(project.time_s) and project.time_s >= 0.0, "the playback time is not a time")
    need(
        project.display.plot_joints in plot_choices(names),
        f"project.display.plot_joints is {project.display.plot_joints!r}, not one of its joints "
        "or legs",
    )
    check_values(project, robot)
