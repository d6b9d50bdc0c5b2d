"""The gait planner from the studio's panel: a real worker process, a real IPOPT solve."""

from __future__ import annotations

import time

import pytest

from tests.studio.conftest import start_studio


@pytest.fixture(scope="module")
def studio(tmp_path_factory):
    studio = start_studio(tmp_path_factory.mktemp("data"))
    yield studio
    studio.stop()


def _wait_idle(studio, timeout_s: float = 180.0) -> None:
    deadline = time.monotonic() + timeout_s
    while studio.gait.running is not None and time.monotonic() < deadline:
        time.sleep(0.1)
    assert studio.gait.running is None, "the solve did not finish"


def test_solve_from_the_panel_then_play_the_gait(studio):
    panel = studio.gait.panel
    assert panel.load_robot.visible  # servo_biped is loaded: the panel offers dircon_biped
    panel.solve.value = True
    _wait_idle(studio)
    result = studio.gait.results[False]
    assert result.converged
    assert "Solved in" in panel.status.content
    assert "max \\|τ\\|" in panel.results.content and "9.8 / 11.5" in panel.results.content
    assert len(studio.gait.history[0]) >= 1  # convergence was reported live
    # Step lengths within what the slack bounds allow: x1 = (0.5 + slack0)(x0 + x2).
    lsp, rsp = result.step_lengths_m
    assert abs(lsp - rsp) <= 2 * 0.05 * (lsp + rsp) + 1e-6
    panel.use.value = True
    assert studio.robot.name == "dircon_biped"
    assert studio.trajectory is not None and studio.trajectory.duration == pytest.approx(
        0.72, abs=0.011
    )
    assert not panel.load_robot.visible


def test_changing_a_setting_marks_the_result_stale(studio):
    panel = studio.gait.panel
    panel.k0.value = 5.0
    assert "stale" in panel.results.content
    panel.k0.value = 6.5
    assert "stale" not in panel.results.content


def test_cancel_keeps_the_last_good_gait(studio):
    panel = studio.gait.panel
    good = studio.gait.results[False]
    panel.knots.value = 80  # a new structure: the worker builds a larger NLP first
    panel.solve.value = True
    time.sleep(0.5)
    begin = time.monotonic()
    panel.cancel.value = True
    deadline = time.monotonic() + 10.0
    while studio.gait.running is not None and time.monotonic() < deadline:
        time.sleep(0.02)
    assert studio.gait.running is None
    print(f"cancel took {time.monotonic() - begin:.3f} s")
    assert "Cancelled" in panel.status.content
    assert studio.gait.results[False] is good
    panel.knots.value = 38
