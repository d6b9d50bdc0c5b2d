"""A planned walk simulated on the robot's sized ideal servos, compensated as the studio
compensates by default, and its SR from electrical energy: what `plan --compare --simulate`
sets beside the paper's Table 4 (whose SR is the real robot's measured motor energy).

The run is `biped-studio simulate WALK --preset uniform --drive-torque` on the walk: the
virtual servos sized to the robot (`files.sized_servos`), the feed-forward of the whole-body
QP (`dynamics.wbc`), eq 7 with k = the servos' compliance on the drive torque τ + D·q̇ + J·q̈
(`drive.plan_drive_torque_Nm`), MuJoCo, then the electrical energy on the ideal servo from
the stated default motor and the SRs (`ideal_energy.run_ideal_sr`): a walk that falls has
its SR over the distance it covered up to the fall.
"""

from __future__ import annotations

import dataclasses

from app.core.motions.trajectory import Trajectory
from app.core.robot.model import RobotModel
from app.core.simulation.ideal_energy import IdealSR
from app.core.simulation.mjcf import SimOptions
from app.core.simulation.result import SimulationResult

COMPENSATION = (
    "eq 7, k = the servos' compliance, on the drive torque τ + D·q̇ + J·q̈ "
    "(simulate --preset uniform --drive-torque)"
)
"""What the walks are compensated with, in one line."""


@dataclasses.dataclass(frozen=True)
class WalkSR:
    """One simulated walk: the run and its energy and SRs."""

    result: SimulationResult
    sr: IdealSR
    servo: str
    """The sized servos, in one line (`scaling.ScaledServo.text`)."""

    def to_json(self) -> dict[str, object]:
        travel = None if self.result.outcome is None else self.result.outcome.travel
        return {
            "verdict": self.result.verdict(),
            "fell": self.result.fell,
            "fall_time_s": self.result.fall_time_s,
            "distance_planned_m": None if travel is None else travel.distance_planned_m,
            "distance_covered_m": None if travel is None else travel.distance_covered_m,
            "ideal_servo_energy": self.sr.to_json(),
        }


def simulate_walk_sr(
    robot: RobotModel, trajectory: Trajectory, label: str, options: SimOptions | None = None
) -> WalkSR:
    """`trajectory` (a walk) simulated as the module docstring says, and its SRs."""
    from app.core.dynamics.wbc import torque_feedforward
    from app.core.servo.compensation import compensated_command
    from app.core.servo.model import joint_angles
    from app.core.servo.presets import preset_params
    from app.core.servo.scaling import scaled_ideal_servo
    from app.core.simulation.drive import plan_drive_torque_Nm
    from app.core.simulation.experiments import clipped_commands, with_note
    from app.core.simulation.files import sized_servos
    from app.core.simulation.ideal_energy import run_ideal_sr
    from app.core.simulation.run import simulate
    from app.core.simulation.servo_law import robot_servo_law

    options = options or SimOptions()
    tau = torque_feedforward(robot, trajectory).tau_Nm
    servo = sized_servos(robot)
    law = robot_servo_law(robot, servo)
    drive = plan_drive_torque_Nm(robot, trajectory, tau, servo, law, options)
    params = preset_params("uniform", robot)
    command = compensated_command(joint_angles(robot, trajectory.q), drive, params)
    clipped, note = clipped_commands(robot, trajectory.t, {label: command})
    result = simulate(robot, trajectory, clipped[label], servo, options, label=label)
    result = with_note({label: result}, note)[label]
    sr = run_ideal_sr(
        result, robot, trajectory, law, lambda: tau, options.timestep_s,
        options.command_hold == "linear",
    )  # fmt: skip
    return WalkSR(result, sr, scaled_ideal_servo(robot).text())
