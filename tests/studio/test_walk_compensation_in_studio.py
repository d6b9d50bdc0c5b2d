"""The studio's walk on servos (issue 26): the one click (plan → walk → torques → simulate) on
servo_biped, then *Compensate* switched to the load torque and simulated again.

Distance is MuJoCo's own root body (`SimulationResult.root_position_m`, read from MuJoCo's
qpos), start to end along x, against the plan's base x; not the verdict's numbers. With the
drive torque compensated (the default, as `simulate --drive-torque`) the walk covers ≥ 90 % of
its planned distance; on the load torque τ alone the swing leg lags by c·D·q̇ and it falls
short (tests/test_cli_walk_simulate.py sees the same from the CLI).
"""

from __future__ import annotations

import numpy as np

from app.core.servo.compensation import compensated_command
from app.core.servo.model import joint_angles
from app.core.simulation.drive import plan_drive_torque_Nm
from app.studio.simulation_runner import WITH
from panels.compensation_panel import COMPENSATED_TORQUE_LABELS
from tests.studio.conftest import one_click, simulate


def _covered(result, trajectory) -> tuple[float, float]:
    """(covered, planned) along x [m]: MuJoCo's root body, the plan's base."""
    root = result.root_position_m
    return float(root[-1, 0] - root[0, 0]), float(trajectory.q[-1, 0] - trajectory.q[0, 0])


def test_the_one_click_walk_covers_its_distance_only_with_the_drive_torque(studio):
    compensation = studio.servo_rooms.compensation.panel
    assert compensation.compensate.value == COMPENSATED_TORQUE_LABELS["drive"]  # the default
    drive = one_click(studio)
    assert drive.error == ""
    walk, robot = studio.gait.walk.trajectory, studio.state.robot
    assert drive.trajectory is walk
    covered, planned = _covered(drive.results[WITH], walk)
    assert planned > 0.3  # four steps of the planned gait and the start / stop
    assert covered >= 0.9 * planned, f"walked {covered:.3f} of {planned:.3f} m"
    assert not drive.results[WITH].fell
    # The commands simulated are eq 7 on the drive torque with the simulated servos' D and J
    # (the same core function as the CLI's --drive-torque), checked against the formula here.
    coefficients = studio.state.work.coefficients
    tau = np.nan_to_num(studio.state.work.torques.tau_Nm)
    expected = compensated_command(
        joint_angles(robot, walk.q),
        plan_drive_torque_Nm(robot, walk, tau, coefficients.servo),
        coefficients.params,
    )
    np.testing.assert_allclose(drive.results[WITH].q_cmd_rad, expected, atol=1e-12)

    # τ alone: the choice re-predicts (the simulation goes stale), then simulate again.
    compensation.compensate.value = COMPENSATED_TORQUE_LABELS["load"]
    assert studio.state.work.coefficients.torque == "load"
    assert studio.state.work.simulation.stale
    load = simulate(studio)
    assert load.error == ""
    covered_load, _ = _covered(load.results[WITH], walk)
    assert covered_load < 0.9 * planned, f"walked {covered_load:.3f} of {planned:.3f} m"
    np.testing.assert_allclose(
        load.results[WITH].q_cmd_rad,
        compensated_command(joint_angles(robot, walk.q), tau, coefficients.params),
        atol=1e-12,
    )
    # the travel line says it, per run
    fraction = load.results[WITH].outcome.travel.fraction
    assert f"({100 * fraction:.0f} %)" in studio.servo_rooms.simulation.panel.verdict.content
