"""The work a project asks of its servos, as torque–speed points per joint, and its sizing.

A *work* is one motion's points: joint speeds and torques (T, n) on the robot's actuated joints
and the sample each point comes from. The current motion gives its feed-forward's points with
the flagged samples left out (no QP solution, or a joint over its speed limit: torques there
are artefacts, app.core.dynamics.peaks); a planned gait gives its planar joints' speeds and
torques sampled every GAIT_SAMPLE_S (the joints a planar gait does not move: no load).
`size_works` sizes every work and combines them (`sizing.combine`): a servo holds a joint when
it holds every work. The CLI's `size` and the studio's *Size servos* both call it.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from app.core.collocation.result import GaitResult
from app.core.dynamics.peaks import over_speed_samples
from app.core.motions.trajectory import Trajectory
from app.core.robot.model import RobotModel
from app.core.servo.catalogue import ServoRecord
from app.core.servo.sizing import (
    CONTINUOUS_FRACTION_OF_STALL,
    Criterion,
    Sizing,
    SizingError,
    combine,
    size_joints,
)

GAIT_SAMPLE_S = 0.01
"""A planned gait's points are taken every 10 ms."""


@dataclasses.dataclass(frozen=True, eq=False)
class Work:
    """One motion's torque–speed points on the robot's actuated joints."""

    speed_rad_s: np.ndarray
    """(T, n)."""
    torque_Nm: np.ndarray
    """(T, n)."""
    sample_index: np.ndarray
    """(T,): the motion's sample of each point."""
    flagged: tuple[int, ...] = ()
    """Samples left out (not solved, or over speed)."""


def motion_work(
    robot: RobotModel, trajectory: Trajectory, tau_Nm: np.ndarray, infeasible: Sequence[int]
) -> Work:
    """The motion's points with its flagged samples left out (SizingError when all are)."""
    flagged = tuple(sorted({*map(int, infeasible), *over_speed_samples(robot, trajectory)}))
    keep = np.setdiff1d(np.arange(trajectory.n_samples), np.array(flagged, dtype=int))
    if len(keep) == 0:
        raise SizingError("every sample of the motion is flagged (not solved or over speed)")
    speed = trajectory.v[:, [j.idx_v for j in robot.joints]]
    return Work(speed[keep], np.asarray(tau_Nm)[keep], keep, flagged)


def gait_work(robot: RobotModel, gait: GaitResult) -> Work | None:
    """A planned gait's points on the robot's joints; None without a gait or for joints that
    are not the robot's."""
    if not gait.has_gait or not set(gait.joint_names) <= set(robot.joint_names):
        return None
    from app.core.collocation.sampling import sample_gait  # casadi: a gait's cost only

    samples = sample_gait(gait, np.arange(0.0, gait.duration_s, GAIT_SAMPLE_S))
    columns = [robot.joint_names.index(name) for name in gait.joint_names]
    w = np.zeros((len(samples.u), robot.n_actuated))
    tau = np.zeros_like(w)
    w[:, columns] = samples.v[:, 3:]
    tau[:, columns] = samples.u
    return Work(w, tau, np.arange(len(w)))


def size_works(
    joint_names: Sequence[str],
    works: dict[str, Work],
    duration_s: float,
    catalogue: dict[str, ServoRecord],
    margin: float = 0.3,
    by: Criterion = "mass",
    continuous_fraction: float = CONTINUOUS_FRACTION_OF_STALL,
) -> Sizing:
    """Every work sized (`size_joints`), combined when there are several (`combine`)."""
    if not works:
        raise SizingError("no motion to size against: compute a motion's torques or plan a gait")
    sizings = {
        label: size_joints(
            joint_names,
            work.speed_rad_s,
            work.torque_Nm,
            duration_s,
            catalogue,
            margin,
            by,
            sample_index=work.sample_index,
            continuous_fraction=continuous_fraction,
        )
        for label, work in works.items()
    }
    return combine(sizings, catalogue) if len(sizings) > 1 else next(iter(sizings.values()))
