"""End to end in a real headless Chromium: a k that pushes the stance hip's command past its
joint limit no longer refuses the simulation; the run happens and the Compensation panel says
the commands were clipped to the limit, naming the joint."""

from __future__ import annotations

import re

import numpy as np
import pytest

from app.studio import Studio
from tests.browser.page_helpers import (
    UI_TIMEOUT_S,
    compute_torques_in_page,
    generate_motion,
    select_option,
    simulate_until_shown,
    type_number,
    wait_for,
)

JOINT = "left_hip_roll"
K_DEG_PER_NM = 20.0
"""The one-leg stand's 3.65 N·m on the stance hip roll times this (the slider's top) is more
than the room to its limit (about 17.4 °/(N·m) reaches it)."""


def test_a_command_past_a_limit_is_simulated_clipped_and_said(page, studio: Studio) -> None:
    generate_motion(page, studio, "one_leg_stand")
    compute_torques_in_page(page, studio, "the prediction")
    select_option(page, "Joint", JOINT)
    wait_for(
        "the Joint pick",
        lambda: studio.servo_rooms.compensation.panel.joint.value == JOINT,
        UI_TIMEOUT_S,
    )
    i = studio.state.robot.joint_names.index(JOINT)
    wait_for(
        f"{JOINT} compensated",
        lambda: studio.state.work.coefficients.params.enabled[i],
        UI_TIMEOUT_S,
    )
    type_number(page, "k [°/(N·m)]", K_DEG_PER_NM)
    wait_for(
        f"k = {K_DEG_PER_NM} on {JOINT}",
        lambda: (
            studio.state.work.coefficients.params.k_deg_per_Nm[i] == pytest.approx(K_DEG_PER_NM)
        ),
        UI_TIMEOUT_S,
    )
    joint = studio.state.robot.joints[i]
    q_cmd = studio.state.work.prediction.q_cmd_rad[:, i]
    assert np.any((q_cmd < joint.lower) | (q_cmd > joint.upper))

    compensation = simulate_until_shown(page)
    note = compensation.get_by_text(re.compile(r"past the joint limits clipped to them"))
    note.first.wait_for(state="visible", timeout=UI_TIMEOUT_S * 1000)
    assert JOINT in note.first.inner_text()
    assert studio.state.work.simulation is not None
    assert studio.state.work.simulation.run.error == ""
