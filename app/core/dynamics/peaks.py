"""Torque peaks that mean something: flagged samples are left out and reported apart.

A sample is flagged when its QP found no solution (its torques are copied from a neighbour)
or when the motion moves a joint faster than its speed limit there (|v_j| > v_max,j, the
limits of app.core.motions.continuity): a jump the real servo cannot follow, whose
accelerations, and so torques, are artefacts. The peak of joint j is

    peak_j = max over unflagged samples k of |τ_kj|   [N·m, or N for a prismatic joint]

and the peak over all samples is kept beside it, so nothing is hidden.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

import numpy as np

from app.core.motions.continuity import speed_limits
from app.core.motions.trajectory import Trajectory
from app.core.robot.model import RobotModel

if TYPE_CHECKING:  # the QP's stack loads where torques are computed, not to sum them up
    from app.core.dynamics.wbc import FeedForward


@dataclasses.dataclass(frozen=True)
class TorquePeaks:
    joint_names: tuple[str, ...]
    max_abs_tau_Nm: np.ndarray
    """Per joint, over the unflagged samples (0 if every sample is flagged), shape (n,)."""
    max_abs_tau_all_samples_Nm: np.ndarray
    """Per joint, over every sample with a finite torque, shape (n,)."""
    infeasible_samples: tuple[int, ...]
    """Samples without a QP solution."""
    over_speed_samples: tuple[int, ...]
    """Samples where a joint moves faster than its speed limit."""

    @property
    def flagged_samples(self) -> tuple[int, ...]:
        return tuple(sorted({*self.infeasible_samples, *self.over_speed_samples}))

    def to_json(self) -> dict[str, object]:
        return {
            "max_abs_tau_Nm": dict(
                zip(self.joint_names, map(float, self.max_abs_tau_Nm), strict=True)
            ),
            "max_abs_tau_all_samples_Nm": dict(
                zip(self.joint_names, map(float, self.max_abs_tau_all_samples_Nm), strict=True)
            ),
            "flagged_samples": {
                "infeasible": list(self.infeasible_samples),
                "over_speed": list(self.over_speed_samples),
            },
        }


def over_speed_samples(robot: RobotModel, traj: Trajectory) -> tuple[int, ...]:
    """Samples where some actuated joint's |v| exceeds its speed limit (relative 1e-6 slack)."""
    idx_v = [j.idx_v for j in robot.joints]
    speeds = np.abs(traj.v[:, idx_v])
    over = speeds > speed_limits(robot)[None, :] * (1.0 + 1e-6)
    return tuple(int(k) for k in np.flatnonzero(over.any(axis=1)))


def torque_peaks(robot: RobotModel, traj: Trajectory, ff: FeedForward) -> TorquePeaks:
    """Peaks of a feed-forward over its unflagged samples (module docstring)."""
    infeasible = tuple(int(k) for k in ff.infeasible_samples)
    fast = over_speed_samples(robot, traj)
    tau = np.abs(ff.tau_Nm)
    finite = np.isfinite(tau)
    clean = finite.copy()
    clean[list({*infeasible, *fast})] = False
    return TorquePeaks(
        joint_names=ff.joint_names,
        max_abs_tau_Nm=np.max(tau, axis=0, initial=0.0, where=clean),
        max_abs_tau_all_samples_Nm=np.max(tau, axis=0, initial=0.0, where=finite),
        infeasible_samples=infeasible,
        over_speed_samples=fast,
    )
