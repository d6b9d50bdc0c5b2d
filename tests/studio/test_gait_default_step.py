"""Roban S14's robot-derived default step (16.9 cm) leaves no start ramp its legs can follow:
the Gait panel's solve shortens it to the longest step whose walk can start (a few more worker
solves), says so in one line, and the walk it gives reaches the gait's speed before the first
lift-off (read off the walk's base x by finite differences, not from the planner)."""

from __future__ import annotations

from app.core.collocation.defaults import robot_gait_defaults
from tests.conftest import ROBAN_URDF
from tests.studio.conftest import wait_for_signal

NOTE = "default steps shortened from"


def test_roban_s14s_default_step_is_shortened_so_its_walk_can_start(studio):
    studio.robots.load(ROBAN_URDF)
    panel = studio.gait.panel
    default = robot_gait_defaults(studio.state.robot).settings.step_length_m
    assert panel.sliders["step_length_m"].value == default
    wait_for_signal(
        studio.gait.finished,
        lambda: setattr(panel.solve, "value", True),
        accept=lambda _ended: NOTE in panel.status.content or "kept:" in panel.status.content,
    )
    step = panel.sliders["step_length_m"].value
    assert f"{NOTE} {50 * default:.1f} to {50 * step:.1f} cm" in panel.status.content
    assert 0.25 * default < step < 0.6 * default
    result = studio.gait.results.symmetric
    assert result.converged and abs(sum(result.step_lengths_m) - step) < 1e-4
    assert "stale" not in panel.results.content  # the panel, the last solve and the gait agree
    panel.use.value = True  # Walk this gait
    walk = studio.gait.walk
    assert walk is not None and not any("jump in speed" in n for n in walk.notes)
    t, x = walk.trajectory.t, walk.trajectory.q[:, 0]
    first_lift = min(f.t_off_s for f in walk.footprints)
    k = int(abs(t - first_lift).argmin())
    dt = t[1] - t[0]
    before, after = (x[k] - x[k - 2]) / (2 * dt), (x[k + 2] - x[k]) / (2 * dt)
    assert after > 0.1 and abs(after - before) < 0.25 * after
    # A later solve of the step found (no longer the default) starts no search.
    ended = wait_for_signal(studio.gait.finished, lambda: setattr(panel.solve, "value", True))
    assert ended.settings.step_length_m == step and studio.gait.default_step.search is None
