"""Motions without jumps: no joint moves further in one sample than its speed limit allows.

Whole-body IK solved sample by sample can switch to another solution between two samples: a
joint the targets do not pin (an arm, when only the CoM is asked for) swings 40–70° in 10 ms.
After each IK solve, the step from the previous sample is measured on the configuration
manifold (δ = q_new ⊖ q_prev, pinocchio.difference) and, when an actuated joint's component
exceeds its limit, the whole step is scaled down uniformly:

    α = min(1, min_j v_max,j·dt / |δ_j|),   q = q_prev ⊕ α·δ   (pinocchio.integrate)

where v_max,j is the joint's URDF velocity limit [rad/s or m/s], or DEFAULT_SPEED_LIMIT when
the URDF gives none. Scaling every joint (and the base) by the same α keeps the motion's
direction: a foot that stands still at both ends moves only to second order in α·δ, where
clipping joints one by one would drag it. The same second-order term opens a closed kinematic
loop (the hybrid leg's four-bars: 2e-5 m on `step_in_place`), so on a robot with loops the
passive joints of the scaled pose are solved again (`close_loops`; actuated joints and base
untouched, so the speed limits still hold). The next sample is warm-started from the scaled
pose, so the IK catches up over the following samples. Every scaled sample is flagged (a
SampleWarning starting with JUMP_PREFIX): its targets were missed on purpose, and its torques
are excluded from peaks.
"""

from __future__ import annotations

import weakref

import numpy as np
import pinocchio as pin

from app.core.robot.loops import close_loops
from app.core.robot.model import RobotModel

DEFAULT_SPEED_LIMIT = 10.0
"""[rad/s] (or m/s) for a joint whose URDF gives no velocity limit: faster than hobby servos
(about 6 rad/s), slow enough that no joint turns more than 5.7° in a 10 ms sample."""
JUMP_PREFIX = "jump:"


def speed_limits(robot: RobotModel) -> np.ndarray:
    """v_max of every actuated joint [rad/s or m/s], in the robot's joint order."""
    return np.array(
        [j.velocity if j.velocity is not None else DEFAULT_SPEED_LIMIT for j in robot.joints]
    )


_SPEEDS: dict[int, tuple[weakref.ref[RobotModel], np.ndarray, np.ndarray]] = {}
"""(the robot, velocity indices, v_max) by id(robot): RobotModel is not hashable."""


def _joint_speeds(robot: RobotModel) -> tuple[np.ndarray, np.ndarray]:
    """(velocity index, v_max) of every actuated joint, computed once per robot (a motion
    asks at every sample)."""
    cached = _SPEEDS.get(id(robot))
    if cached is None or cached[0]() is not robot:
        if len(_SPEEDS) > 32:  # robots come and go in a long-lived studio
            _SPEEDS.clear()
        idx_v = np.array([j.idx_v for j in robot.joints], dtype=int)
        cached = (weakref.ref(robot), idx_v, speed_limits(robot))
        _SPEEDS[id(robot)] = cached
    return cached[1], cached[2]


def limit_joint_steps(
    robot: RobotModel, q_prev: np.ndarray, q_new: np.ndarray, dt: float
) -> tuple[np.ndarray, str | None]:
    """(q, message): the step from q_prev to q_new scaled so that no actuated joint moves more
    than v_max·dt (module docstring); message is None when the step was within the limits,
    else names the joint that set the scale."""
    delta = pin.difference(robot.model, q_prev, q_new)
    idx_v, v_max = _joint_speeds(robot)
    limits = v_max * dt
    steps = delta[idx_v]
    over = np.abs(steps) > limits * (1.0 + 1e-9)
    if not over.any():
        return q_new, None
    ratios = np.abs(steps) / limits
    worst = int(np.argmax(ratios))
    joint = robot.joints[worst]
    unit = "m" if joint.kind == "prismatic" else "°"
    scale = 1.0 if joint.kind == "prismatic" else 180.0 / np.pi
    alpha = 1.0 / float(ratios[worst])
    message = (
        f"{JUMP_PREFIX} the IK moved {joint.name} {abs(steps[worst]) * scale:.1f}{unit} in one "
        f"sample, its speed limit allows {limits[worst] * scale:.2g}{unit}; the step was "
        "scaled to the limit"
    )
    q = pin.integrate(robot.model, q_prev, alpha * delta)
    if robot.tree.loops:
        q = close_loops(robot, q, robot.model.createData()).q
    return q, message
