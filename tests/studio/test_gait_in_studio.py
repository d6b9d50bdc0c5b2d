"""The gait planner from the studio's panel: a real worker process, a real IPOPT solve."""

from __future__ import annotations

import pytest

from app.core.papers import TABLE4
from tests.studio.conftest import solve_gait, wait_for_signal


def test_solve_from_the_panel_then_play_the_gait(studio):
    panel = studio.gait.panel
    assert panel.load_robot.visible  # servo_biped is loaded: the panel offers dircon_biped
    ended = solve_gait(studio)
    result = studio.gait.results.symmetric
    assert ended.result is result and result.converged
    assert "Solved in" in panel.status.content
    assert "max \\|τ\\|" in panel.results.content
    assert f"{TABLE4.max_abs_tau_Nm[0]} / {TABLE4.max_abs_tau_Nm[1]}" in panel.results.content
    assert len(studio.gait.history[0]) >= 1  # convergence was reported live
    # Step lengths within what the slack bounds allow: x1 = (0.5 + slack0)(x0 + x2).
    lsp, rsp = result.step_lengths_m
    assert abs(lsp - rsp) <= 2 * 0.05 * (lsp + rsp) + 1e-6
    panel.use.value = True
    assert studio.state.robot.name == "dircon_biped"
    assert studio.state.trajectory is not None
    assert studio.state.trajectory.duration == pytest.approx(0.72, abs=0.011)
    assert not panel.load_robot.visible


def test_changing_a_setting_marks_the_result_stale(studio):
    panel = studio.gait.panel
    solve_gait(studio)
    assert "stale" not in panel.results.content
    panel.sliders["K0"].value = 5.0
    assert "stale" in panel.results.content
    panel.sliders["K0"].value = 6.5
    assert "stale" not in panel.results.content


def test_a_crafted_knot_count_is_refused_before_the_worker_builds(studio):
    """A client can send values the slider would never allow (knots = 400)."""
    panel = studio.gait.panel
    panel.sliders["knots"]._impl.value = 400.0  # what a crafted websocket message sets
    assert studio.gait.solve(baseline=False) is None
    assert studio.gait.running is None
    assert "knots" in panel.status.content and "80" in panel.status.content


def test_cancel_keeps_the_last_good_gait(studio):
    panel = studio.gait.panel
    solve_gait(studio)
    good = studio.gait.results.symmetric
    panel.sliders["knots"].value = 80  # a new structure: the worker builds a larger NLP first

    def solve_then_cancel() -> None:
        panel.solve.value = True
        panel.cancel.value = True

    ended = wait_for_signal(studio.gait.finished, solve_then_cancel)
    assert ended.error == "cancelled"
    assert studio.gait.running is None
    assert "Cancelled" in panel.status.content
    assert studio.gait.results.symmetric is good
