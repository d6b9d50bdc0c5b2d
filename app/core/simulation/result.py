"""What a simulation run gives: the motion as the physics played it, and a verdict
(`verdicts.Verdict`: stays up, leans on the lifted foot, slips, falls; how far it travelled)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from app.core.simulation.balance_feedback import BalanceGains
from app.core.simulation.part_law import PartEnergy
from app.core.simulation.verdicts import Verdict


@dataclasses.dataclass(frozen=True, eq=False)
class SimulationResult:
    """One simulated run, sampled at the motion's times. After a fall the simulation stops
    `POST_FALL_S` later and the remaining samples repeat the last state."""

    label: str
    robot_name: str
    joint_names: tuple[str, ...]
    t: np.ndarray
    """Sample times [s], shape (T,), the motion's."""
    q: np.ndarray
    """Configurations (T, nq), pinocchio layout: base xyz [m], quaternion xyzw, joints."""
    v: np.ndarray
    """Generalised velocities (T, nv), pinocchio layout (base twist in the base frame)."""
    q_cmd_rad: np.ndarray
    """Servo commands sent [rad], shape (T, n) (with the balance feedback's offsets when it
    ran)."""
    q_joints_rad: np.ndarray
    """Actuated joint angles [rad], shape (T, n)."""
    tau_Nm: np.ndarray
    """Servo torques [N·m], shape (T, n), during the 10 ms after each sample."""
    roll_rad: np.ndarray
    pitch_rad: np.ndarray
    """Torso (root link) roll and pitch in the world [rad], ZYX convention, shape (T,)."""
    roll_planned_rad: np.ndarray
    pitch_planned_rad: np.ndarray
    contact_force_N: np.ndarray
    """Floor force on the (left, right) sole in the world frame [N], shape (T, 2, 3)."""
    sole_position_m: np.ndarray
    """(left, right) sole centres in the world [m], shape (T, 2, 3)."""
    slip_m: np.ndarray
    """Horizontal distance each sole has slid since it last touched down [m], shape (T, 2);
    0 while it is in the air."""
    fell: bool
    fall_time_s: float | None
    """Time of the first sample at which the robot had fallen, None if it stays up."""
    fall_reason: str
    simulated_until_s: float
    rms_joint_error_deg: float
    """√(mean over samples and joints of (q − q_plan)²) [°], up to `simulated_until_s`."""
    wall_time_s: float
    real_time_factor: float
    """Simulated time (settling included) over wall time."""
    notes: tuple[str, ...] = ()
    energy: PartEnergy | None = None
    """Per-joint electrical energy, with servo parts (`part_law`); None with virtual servos."""
    root_position_m: np.ndarray | None = None
    """The root body's origin in the world [m], shape (T, 3), MuJoCo's own `xpos` (None in
    projects saved before it was kept)."""
    outcome: Verdict | None = None
    """What the run did, with its numbers (`verdict()` is its one line); None in projects
    saved before verdicts had names (`verdict()` then gives the fall test's line)."""
    balance_feedback: BalanceGains | None = None
    """The balance feedback's gains when the run had it (`balance_feedback`), else None."""
    balance_offsets_rad: np.ndarray | None = None
    """What the feedback added to each command [rad], shape (T, n); None without it."""

    @property
    def roll_error_deg(self) -> np.ndarray:
        return np.degrees(self.roll_rad - self.roll_planned_rad)

    @property
    def pitch_error_deg(self) -> np.ndarray:
        return np.degrees(self.pitch_rad - self.pitch_planned_rad)

    def verdict(self) -> str:
        """One line: "stays up", "leans on the lifted foot: …", "slips: …" or "falls at 3.42 s
        (reason)", then what else happened (app.core.simulation.verdicts)."""
        if self.outcome is not None:
            return self.outcome.text
        if not self.fell:
            return "stays up"
        return f"falls at {self.fall_time_s:.2f} s ({self.fall_reason})"

    def summary(self) -> dict[str, object]:
        """The numbers the CLI prints with --json."""
        shown = self.t <= self.simulated_until_s
        return {
            "label": self.label,
            "fell": self.fell,
            "fall_time_s": self.fall_time_s,
            "fall_reason": self.fall_reason or None,
            **({"verdict": self.verdict()} if self.outcome is None else self.outcome.summary()),
            "max_abs_roll_deg": math.degrees(float(np.max(np.abs(self.roll_rad[shown])))),
            "max_abs_pitch_deg": math.degrees(float(np.max(np.abs(self.pitch_rad[shown])))),
            "max_roll_error_deg": float(np.max(np.abs(self.roll_error_deg[shown]))),
            "max_pitch_error_deg": float(np.max(np.abs(self.pitch_error_deg[shown]))),
            "rms_joint_error_deg": self.rms_joint_error_deg,
            "max_slip_m": float(self.slip_m[shown].max()),
            "simulated_until_s": self.simulated_until_s,
            "wall_time_s": self.wall_time_s,
            "real_time_factor": self.real_time_factor,
            "notes": list(self.notes),
            "balance_feedback": {
                "on": self.balance_feedback is not None,
                "gains": None if self.balance_feedback is None else self.balance_feedback.to_json(),
            },
        }


def slip_m(sole_position_m: np.ndarray, in_contact: np.ndarray) -> np.ndarray:
    """Per sample and sole, the horizontal distance [m] from where the sole was when its
    current contact began; 0 out of contact. Shapes (T, 2, 3), (T, 2) → (T, 2)."""
    out = np.zeros(in_contact.shape)
    for side in range(in_contact.shape[1]):
        anchor = None
        for k in range(len(in_contact)):
            if not in_contact[k, side]:
                anchor = None
                continue
            if anchor is None:
                anchor = sole_position_m[k, side, :2]
            out[k, side] = float(np.linalg.norm(sole_position_m[k, side, :2] - anchor))
    return out
