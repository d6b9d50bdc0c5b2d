"""Trajectory: a whole-body motion sampled at a fixed time step, with its contact schedule.

This is what every stage of the pipeline passes on: keyframed motions and gait plans produce
it; playback, torque feed-forward, compensation and CSV export consume it. Configurations use
pinocchio's layout (see app.core.robot.model).

Velocities and accelerations are computed from the configurations by finite differences on
the configuration manifold (pin.difference, so the base orientation is handled properly):
central differences inside (the mean of the two one-step differences,
v_k = (q_k ⊖ q_{k-1} + q_{k+1} ⊖ q_k) / (2 dt), and a_k = (q_{k+1} ⊖ q_k − q_k ⊖ q_{k-1}) / dt²),
one-sided for v at the ends (a there repeats its neighbour), as the spring-compensation paper computes them
"by finite differences at a small dt". Both are second-order accurate for smooth motions.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pinocchio as pin

from app.core.errors import StudioError


class TrajectoryError(StudioError):
    """A trajectory that is malformed or does not fit the robot."""


@dataclasses.dataclass(frozen=True)
class Trajectory:
    """A motion sampled every `dt` seconds from t = 0."""

    name: str
    joint_names: tuple[str, ...]
    """Actuated joints of the robot, in the robot's order."""
    t: np.ndarray
    """Sample times [s], shape (T,), uniform, starting at 0."""
    q: np.ndarray
    """Configurations, shape (T, nq): base xyz [m], base quaternion xyzw, joint positions."""
    v: np.ndarray
    """Generalised velocities, shape (T, nv): base linear [m/s] and angular [rad/s] velocity in
    the base frame (pinocchio's convention), joint velocities [rad/s or m/s]."""
    a: np.ndarray
    """Generalised accelerations, shape (T, nv), same frames, [m/s²], [rad/s²]."""
    contacts: np.ndarray
    """Which feet are in contact, shape (T, 2) bool: (left, right)."""

    def __post_init__(self) -> None:
        n = len(self.t)
        if n < 2:
            raise TrajectoryError(
                f"trajectory {self.name!r} has {n} sample(s); at least 2 are needed"
            )
        for label, array, width in (("q", self.q, None), ("v", self.v, None), ("a", self.a, None)):
            if (
                array.ndim != 2
                or array.shape[0] != n
                or (width is not None and array.shape[1] != width)
            ):
                raise TrajectoryError(
                    f"trajectory {self.name!r}: {label} has shape {array.shape}, expected ({n}, …)"
                )
            if not np.all(np.isfinite(array)):
                raise TrajectoryError(
                    f"trajectory {self.name!r}: {label} contains NaN or infinite values"
                )
        if self.contacts.shape != (n, 2):
            raise TrajectoryError(
                f"trajectory {self.name!r}: contacts has shape {self.contacts.shape}, expected ({n}, 2)"
            )
        steps = np.diff(self.t)
        if (
            not np.all(np.isfinite(self.t))
            or steps.min() <= 0.0
            or np.ptp(steps) > 1e-6 * steps.mean()
        ):
            raise TrajectoryError(
                f"trajectory {self.name!r}: sample times must increase by a fixed step"
            )

    @property
    def dt(self) -> float:
        return float(self.t[1] - self.t[0])

    @property
    def duration(self) -> float:
        return float(self.t[-1] - self.t[0])

    @property
    def n_samples(self) -> int:
        return len(self.t)

    def index_at(self, time_s: float) -> int:
        """Index of the sample nearest to a time, clamped to the trajectory."""
        return int(np.clip(round((time_s - self.t[0]) / self.dt), 0, self.n_samples - 1))


def from_configurations(
    model: pin.Model,
    name: str,
    joint_names: tuple[str, ...],
    dt: float,
    q: np.ndarray,
    contacts: np.ndarray,
) -> Trajectory:
    """A Trajectory whose v and a are finite differences of the configurations q (T, nq)."""
    q = np.asarray(q, dtype=float)
    n = len(q)
    if n < 2 or not dt > 0.0:
        raise TrajectoryError(
            f"trajectory {name!r} needs at least 2 samples and dt > 0 (got {n}, {dt})"
        )
    if q.shape[1] != model.nq:
        raise TrajectoryError(
            f"trajectory {name!r}: configurations have {q.shape[1]} values, the robot {model.nq}"
        )
    steps = np.array([pin.difference(model, q[k], q[k + 1]) for k in range(n - 1)]) / dt
    v = np.empty((n, model.nv))
    v[0], v[-1] = steps[0], steps[-1]
    v[1:-1] = 0.5 * (steps[:-1] + steps[1:])
    a = np.zeros((n, model.nv))
    if n >= 3:
        a[1:-1] = (steps[1:] - steps[:-1]) / dt
        a[0], a[-1] = a[1], a[-2]
    return Trajectory(
        name=name,
        joint_names=tuple(joint_names),
        t=np.arange(n) * dt,
        q=q,
        v=v,
        a=a,
        contacts=np.asarray(contacts, dtype=bool).reshape(n, 2),
    )


def repeated(trajectory: Trajectory, times: int) -> Trajectory:
    """The motion played `times` over back to back (a long motion made from a short one)."""
    n = trajectory.n_samples * times
    return dataclasses.replace(
        trajectory,
        name=f"{trajectory.name} ×{times}",
        t=np.arange(n) * trajectory.dt,
        q=np.tile(trajectory.q, (times, 1)),
        v=np.tile(trajectory.v, (times, 1)),
        a=np.tile(trajectory.a, (times, 1)),
        contacts=np.tile(trajectory.contacts, (times, 1)),
    )
