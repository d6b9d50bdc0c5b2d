"""The torque feed-forward's parameters (WbcParams: the whole-body QP's and the CoM LQR's, each
checked on construction), its error type, and the torque limits they resolve to for a robot.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from app.core.errors import StudioError
from app.core.robot.model import RobotModel


class WbcError(StudioError):
    """A torque feed-forward that cannot be computed for these inputs."""


@dataclasses.dataclass(frozen=True)
class WbcParams:
    """Parameters of the whole-body QP (eq. 12–18) and of the CoM LQR (eqs. 1–5)."""

    mu: float = 0.7
    """Coulomb friction coefficient of the pyramids (eq. 11). The paper gives no value; 0.7
    is a common rubber-sole-on-floor figure (the gait paper plans with 0.6)."""
    alpha: float = 10.0
    """No-slip gain α of eq. 14 [1/s] (not given in the paper)."""
    w_qdd: float = 100.0
    """Weight of ‖q̈_des − q̈‖² in eq. 12 [per (rad/s²)²] (not given in the paper). 100 ≫ the
    unit weight of ‖η‖² makes the plan authoritative: the slack absorbs the small foot
    accelerations finite differences leave in a plan, instead of q̈ bending away from it."""
    epsilon: float = 1e-6
    """ε of eq. 12 [per N²] (not given): only picks the smallest spread of forces over the
    corners; 1e-4 already bends q̈ of a 29 kg robot by ~4e-3 rad/s² on one leg."""
    eta_max: float = 10.0
    """Bound of the no-slip slack η of eq. 18 [m/s², rad/s²] (not given)."""
    lqr_q: float = 10.0
    """Q = lqr_q·I₆ of the CoM LQR (paper: 10)."""
    lqr_r: float = 0.1
    """R = lqr_r·I₃ of the CoM LQR (paper: 0.1)."""
    a: float = 0.1
    """Feed-through a of the CoM output y = p + a·u (eq. 1; paper: 0.1) [s²]."""
    torque_limits_Nm: tuple[float | None, ...] | None = None
    """|τ| bound per actuated joint [N·m or N], robot order (eq. 15). None: the URDF's effort
    limits; a joint without one (None here or in the URDF) is unbounded."""
    max_qdd_error: float = 0.1
    """A sample is "solved" when max |q̈ − q̈_des| stays below this [rad/s² or m/s²]."""

    def __post_init__(self) -> None:
        positive = {
            "mu": self.mu,
            "w_qdd": self.w_qdd,
            "epsilon": self.epsilon,
            "eta_max": self.eta_max,
            "lqr_q": self.lqr_q,
            "lqr_r": self.lqr_r,
            "max_qdd_error": self.max_qdd_error,
        }
        for name, value in {**positive, "alpha": self.alpha, "a": self.a}.items():
            bad = not math.isfinite(value) or value < 0.0 or (name in positive and value == 0.0)
            if bad:
                kind = "positive" if name in positive else "non-negative"
                raise WbcError(f"WBC parameter {name} must be a {kind} number, got {value!r}")
        for limit in self.torque_limits_Nm or ():
            if limit is not None and not (math.isfinite(limit) and limit >= 0.0):
                raise WbcError(f"torque limits must be non-negative numbers or None, got {limit!r}")


def torque_limits(robot: RobotModel, params: WbcParams) -> tuple[np.ndarray, list[str]]:
    """|τ| bound per actuated joint [N·m or N], inf where unbounded, and the unbounded names."""
    if params.torque_limits_Nm is None:
        limits = [joint.effort for joint in robot.joints]
    elif len(params.torque_limits_Nm) != robot.n_actuated:
        raise WbcError(
            f"{len(params.torque_limits_Nm)} torque limits given; {robot.name!r} has "
            f"{robot.n_actuated} actuated joints: {', '.join(robot.joint_names)}"
        )
    else:
        limits = list(params.torque_limits_Nm)
    bound = np.array([np.inf if limit is None else limit for limit in limits], dtype=float)
    return bound, [name for name, b in zip(robot.joint_names, bound, strict=True) if np.isinf(b)]
