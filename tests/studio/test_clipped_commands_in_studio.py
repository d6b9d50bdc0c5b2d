"""A compensation that pushes a computed command past a joint limit: the studio's simulation
clips it to the limit, as a servo clips its goal (and as `simulate` does), and says so."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from tests.studio.conftest import simulate, with_stand_torques

JOINT = "left_hip_roll"
K_DEG_PER_NM = 19.5
"""Eq 7's k on the stance hip roll: its 3.65 N·m of the one-leg stand times k is more than the
joint's room to its limit (the stand needs about 17.4 °/(N·m) to reach it)."""


def urdf_limits(robot) -> tuple[np.ndarray, np.ndarray]:
    """The actuated joints' limits as pinocchio reads them from the URDF (not the studio's)."""
    model = pin.buildModelFromUrdf(str(robot.source))
    index = [model.getJointId(name) for name in robot.joint_names]
    q_index = [model.joints[i].idx_q for i in index]
    return model.lowerPositionLimit[q_index], model.upperPositionLimit[q_index]


def test_a_command_past_a_limit_is_clipped_to_it_and_the_run_says_so(studio):
    with_stand_torques(studio)
    panel = studio.servo_rooms.compensation.panel
    panel.joint.value = JOINT
    panel.enabled.value = True
    panel.k.value = K_DEG_PER_NM
    robot, prediction = studio.state.robot, studio.state.work.prediction
    lower, upper = urdf_limits(robot)
    i = robot.joint_names.index(JOINT)
    q_cmd = prediction.q_cmd_rad.copy()
    past = (q_cmd < lower) | (q_cmd > upper)
    assert past[:, i].any()  # the compensation asks the hip past its limit

    ended = simulate(studio)

    assert ended.error == "" and studio.state.work.simulation.run is ended  # it ran
    (_without, with_) = ended.job.inputs
    np.testing.assert_array_equal(with_.q_cmd_rad, np.minimum(np.maximum(q_cmd, lower), upper))
    np.testing.assert_array_equal(ended.job.inputs[0].q_cmd_rad, prediction.q_plan_rad)
    verdict = studio.servo_rooms.simulation.panel.verdict.content
    k, j = np.argwhere(past)[0]  # the first command past a limit, in time then joint order
    (note,) = [line for line in verdict.split("  \n") if "clipped" in line]
    assert (
        note.startswith("note: ")
        and f"first {robot.joint_names[j]} at t = {studio.state.trajectory.t[k]:.2f} s" in note
    )
    assert f"{int(past.sum())} compensated command(s)" in note
    assert all(note[len("note: ") :] in run.notes for run in ended.results.values())
