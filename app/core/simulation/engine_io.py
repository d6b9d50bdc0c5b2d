"""What the step loop (`engine.run_engine`) takes and gives: picklable values only, so a run
can go to a worker process without pinocchio."""

from __future__ import annotations

import dataclasses

import numpy as np

from app.core.simulation.balance_feedback import BalanceFeedback
from app.core.simulation.part_law import PartEnergy
from app.core.simulation.servo_law import ServoLaw
from app.core.simulation.sim_model import SimModel

__all__ = ["EngineInput", "EngineRun"]


@dataclasses.dataclass(frozen=True, eq=False)
class EngineInput:
    sim: SimModel
    law: ServoLaw
    q0: np.ndarray
    """First configuration, pinocchio layout (nq,)."""
    q_cmd_rad: np.ndarray
    """Servo commands (T, n)."""
    dt_cmd_s: float
    settle_s: float
    root_height_planned_m: np.ndarray
    """Planned root height above the floor (T,), for the fall verdict."""
    roll_planned_rad: np.ndarray
    pitch_planned_rad: np.ndarray
    linear_hold: bool = False
    """Ramp the set point linearly from one command to the next instead of holding it."""
    on_floor: bool = True
    """Put the lowest sole corner `DROP_M` above the floor first (else start at q0 as is)."""
    detect_falls: bool = True
    servo_in_mujoco: bool = True
    """The ideal servo's torque computed by MuJoCo's actuators (`servo_law.actuators_xml`),
    a block of samples per call (`blocks`); False: the law in Python at every
    tick into `qfrc_applied` (`ServoLoop`, `PartLoop`: the reference the tests compare
    with). Servo parts with m6 friction (`PartLaw.in_mujoco`) always run in Python."""
    balance: BalanceFeedback | None = None
    """The optional balance feedback (`balance_feedback`): once per sample, the torso's
    roll/pitch error to the stance legs' ankle and hip commands (while settling too)."""


@dataclasses.dataclass(frozen=True, eq=False)
class EngineRun:
    q: np.ndarray
    """Configurations (T, nq), pinocchio layout."""
    v: np.ndarray
    """Velocities (T, nv), pinocchio layout (base twist in the base frame)."""
    q_joints_rad: np.ndarray
    tau_Nm: np.ndarray
    """Servo torques applied during the step that follows each sample (T, n)."""
    roll_rad: np.ndarray
    pitch_rad: np.ndarray
    contact_force_N: np.ndarray
    """Floor force on each sole, world frame (T, 2, 3)."""
    sole_position_m: np.ndarray
    """Sole centres in the world (T, 2, 3)."""
    root_position_m: np.ndarray
    """The root body's origin in the world (T, 3) [m], MuJoCo's `xpos`."""
    non_foot_contact: np.ndarray
    """(T,) bool."""
    fall_index: int
    """First sample at which the robot has fallen, −1 if never."""
    fall_reason: str
    floor_link: str
    """The first link other than a foot on the floor from the fall on ("" if none, or no
    fall)."""
    floor_link_index: int
    """The sample at which `floor_link` was first on the floor, −1 if none."""
    n_simulated: int
    wall_time_s: float
    energy: PartEnergy | None = None
    """Per-joint energy over the recorded motion, with servo parts (`part_law`)."""
    balance_offsets_rad: np.ndarray | None = None
    """What the balance feedback added to each command (T, n) [rad]; None without it."""
