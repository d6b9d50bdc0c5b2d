"""A sweep whose points cannot walk, on a real Dask worker through the Sweep panel's handles:
every point is counted (done = solved + failed + cancelled), each failed point is listed with its
one-line reason, drawn in the plot's failed strip (the panel's and the clickable one in the 3D
view), and picking it shows why it failed and keeps Load point off."""

from __future__ import annotations

import numpy as np

from app.core.sweeps.outcomes import outcome_of
from tests.studio.conftest import run_sweep, set_sweep, wait_for_signal


def test_points_too_fast_for_the_motors_fail_and_are_counted_listed_drawn_and_picked(studio):
    session, panel = studio.sweep, studio.sweep.panel
    assert studio.robots.load("dircon_biped")
    # two steps of 0.55-0.6 m in 0.3 s (about 2 m/s on legs of 0.8 m): more than the joints'
    # 13 N·m can drive, so the planner finds no gait
    set_sweep(panel, ("gait:step_length_m", 0.55, 0.6), ("gait:H_s", 0.3, 0.3), samples=2)
    outcome = run_sweep(studio)
    assert not outcome.error and not outcome.cancelled
    assert sorted(r.index for r in outcome.results) == [0, 1]
    assert not any(r.solved for r in outcome.results), [r.status for r in outcome.results]
    assert "2 / 2 done: 0 solved, 2 failed, 0 cancelled" in panel.status.content

    listed = panel.failures.content
    assert "Failed points (2)" in listed
    for r in outcome.results:
        step = r.values[0]
        assert 0.55 <= step <= 0.6
        line = outcome_of(r, simulate=False).line()
        assert line.startswith("gait: ") and "torque bound" in line and "\n" not in line
        assert f"#{r.index} (step_length_m = {step:.4g}, H_s = 0.3): {line}" in listed

    # drawn: both in the failed strip of the panel's plot, none elsewhere
    assert panel.plot is not None
    _x, designs, fell, front, failed = panel.plot.data
    assert np.count_nonzero(np.isfinite(failed)) == 2
    assert not np.isfinite(np.concatenate([designs, fell, front])).any()
    # and on the board in the 3D view, side by side
    board = session.picker.board
    where = [board.world_position(r.index) for r in outcome.results]
    assert all(w is not None for w in where)
    assert np.linalg.norm(where[0] - where[1]) > 0.01

    # no front: the panel picks the point its number names, and says why it failed
    first = session.picker.selected
    assert first == panel.point.value == 0
    assert "**Point #0**" in panel.selected.content and "failed (gait)" in panel.selected.content
    assert panel.load_button.disabled  # nothing to load
    # picked by its number typed
    panel.point.value = 1
    assert session.picker.selected == 1 and "**Point #1**" in panel.selected.content
    assert "torque bound" in panel.selected.content and panel.load_button.disabled
    # picked as the board's click handler does (the browser test clicks it for real)
    picked = wait_for_signal(session.picker.on_selected, lambda: session.select(0, None))
    assert picked == 0 and panel.point.value == 0 and "**Point #0**" in panel.selected.content
