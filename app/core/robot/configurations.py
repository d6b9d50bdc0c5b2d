"""Whether configurations are ones the robot can take: what every load checks before a pose
or motion is installed (a motion file, a project, an autosave).

A configuration q (pinocchio layout) is accepted when, joint by joint of the robot's model:

- a free-flyer base (nq = 7) stands within ±MAX_POSITION_M of the origin and its orientation
  is a unit quaternion (| ‖quat‖ − 1 | ≤ QUATERNION_TOLERANCE): a zero or scaled quaternion
  is not a rotation;
- an unbounded revolute joint (nq = 2: cos θ, sin θ) lies on the unit circle, same tolerance;
- a one-coordinate joint (revolute, prismatic) lies within its URDF limits, with
  JOINT_TOLERANCE to spare (recorded motions sit up to ~2e-4 rad past their robot's limits:
  Roban S14's new-year dance), and within ±MAX_POSITION_M in any case.

A motion's velocities and accelerations must be below MAX_SPEED and MAX_ACCELERATION (in the
joints' units; far above any robot, only absurd values such as 1e308 are refused). Each check
names the place, the sample and the joint: one line for the user.
"""

from __future__ import annotations

import numpy as np

from app.core.errors import StudioError
from app.core.robot.model import RobotModel

JOINT_TOLERANCE = 0.01
"""How far past its limits a joint may sit [rad or m]."""
QUATERNION_TOLERANCE = 1e-3
"""How far from 1 the norm of a base quaternion (or a cos/sin pair) may be."""
MAX_POSITION_M = 1.0e4
"""Farthest base position from the origin [m] (and largest joint coordinate)."""
MAX_SPEED = 1.0e3
"""Largest velocity component accepted [rad/s or m/s]."""
MAX_ACCELERATION = 1.0e6
"""Largest acceleration component accepted [rad/s² or m/s²] (recorded motions reach ~5e3)."""


class ConfigurationError(StudioError):
    """A configuration the robot cannot take (the message names the place and the joint)."""


def check_configurations(
    robot: RobotModel,
    q: np.ndarray,
    where: str,
    t: np.ndarray | None = None,
    limits: bool = True,
) -> None:
    """ConfigurationError unless every row of `q` (shape (nq,) or (T, nq)) is a configuration
    of `robot` (module docstring). `t`: the rows' times, to say when; `limits`: False skips the
    joint limits (a simulated run may press past them)."""
    model = robot.model
    rows = np.atleast_2d(np.asarray(q, dtype=float))
    if rows.ndim != 2 or rows.shape[1] != model.nq:
        raise ConfigurationError(f"{where}: configurations of {model.nq} values are needed")
    if not np.all(np.isfinite(rows)):
        raise ConfigurationError(f"{where} contains NaN or infinite values")

    def fail(sample: int, message: str) -> None:
        when = ""
        if rows.shape[0] > 1 or np.ndim(q) == 2:
            when = f", sample {sample}" + (
                f" (t = {float(t[sample]):.3f} s)" if t is not None else ""
            )
        raise ConfigurationError(f"{where}{when}: {message}")

    for i in range(1, model.njoints):
        joint = model.joints[i]
        name, start, nq = model.names[i], joint.idx_q, joint.nq
        values = rows[:, start : start + nq]
        if nq == 7:  # free flyer: position, quaternion xyzw
            far = np.flatnonzero(np.abs(values[:, :3]).max(axis=1) > MAX_POSITION_M)
            if len(far):
                k = int(far[0])
                fail(k, f"the base is at {_show(values[k, :3])} m, beyond ±{MAX_POSITION_M:g} m")
            _unit(values[:, 3:], "the base orientation", "a unit quaternion", fail)
        elif nq == 2:  # unbounded revolute: (cos, sin)
            _unit(values, f"joint {name}", "a unit (cos, sin) pair", fail)
        elif nq == 1:
            _within(model, start, name, values[:, 0], limits, fail)


def check_motion_rates(v: np.ndarray, a: np.ndarray, where: str) -> None:
    """ConfigurationError unless every velocity and acceleration is below its sanity bound."""
    for label, array, bound, unit in (
        ("velocities", v, MAX_SPEED, "rad/s or m/s"),
        ("accelerations", a, MAX_ACCELERATION, "rad/s² or m/s²"),
    ):
        if array.size and not np.abs(array).max() <= bound:
            k = int(np.argmax(np.abs(array).max(axis=-1))) if array.ndim == 2 else 0
            raise ConfigurationError(
                f"{where}: {label} reach {float(np.abs(array).max()):.3g} at sample {k}; "
                f"beyond the {bound:g} {unit} any robot can move"
            )


def _unit(values: np.ndarray, what: str, kind: str, fail) -> None:
    norms = np.linalg.norm(values, axis=1)
    bad = np.flatnonzero(np.abs(norms - 1.0) > QUATERNION_TOLERANCE)
    if len(bad):
        k = int(bad[0])
        fail(k, f"{what} {_show(values[k])} is not {kind} (norm {norms[k]:.3g})")


def _within(model, start: int, name: str, values: np.ndarray, limits: bool, fail) -> None:
    lower, upper = float(model.lowerPositionLimit[start]), float(model.upperPositionLimit[start])
    bounded = limits and np.isfinite(lower) and np.isfinite(upper) and lower <= upper
    if bounded and abs(lower) < MAX_POSITION_M and abs(upper) < MAX_POSITION_M:
        lo, hi = lower - JOINT_TOLERANCE, upper + JOINT_TOLERANCE
        bad = np.flatnonzero((values < lo) | (values > hi))
        if len(bad):
            k = int(bad[0])
            fail(
                k,
                f"joint {name} is at {values[k]:.4g}, beyond its limits [{lower:.4g}, {upper:.4g}]",
            )
    far = np.flatnonzero(np.abs(values) > MAX_POSITION_M)
    if len(far):
        k = int(far[0])
        fail(k, f"joint {name} is at {values[k]:.4g}, beyond ±{MAX_POSITION_M:g}")


def _show(values: np.ndarray) -> str:
    return "(" + ", ".join(f"{float(x):.4g}" for x in values) + ")"
