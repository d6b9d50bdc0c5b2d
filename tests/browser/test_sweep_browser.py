"""End to end in a real headless Chromium: run a small sweep from the "Sweep" folder, see the
counts and the Pareto plot drawn, turn the camera to the plot in the 3D view and click a point
on it (the panel shows the point picked), then type a point of the front and load it (its robot
and a walk of its gait).

viser's GUI plots report no clicks, so the clickable plot is a board of scene nodes beside the
robot: the test projects a point's position through the camera the tab reports (the pinhole
model three.js draws with) onto the page and clicks there, as a user would.

The page is loaded once for the module (software WebGL is slow)."""

from __future__ import annotations

import contextlib

import numpy as np
import pytest

from app.studio import Studio
from tests.browser.page_helpers import (
    RENDER_TIMEOUT_S,
    UI_TIMEOUT_S,
    click_button,
    dismiss_software_webgl_warning,
    expand_folder,
    folder,
    folder_title,
    scene_canvas_box,
    screen_point,
    type_number,
    wait_for,
)

SWEEP = "Sweep"
SWEEP_TIMEOUT_S = 600.0
"""Start a 2-worker cluster, build a 14-knot NLP in each, solve 3 points (a shared machine)."""


@pytest.fixture(scope="module")
def studio_robot() -> str:
    """The panel sweeps the loaded robot: the planner's paper robot here."""
    return "dircon_biped"


@pytest.fixture(scope="module")
def page(browser_page, studio_url: str):
    browser_page.set_default_timeout(120_000)  # a busy shared machine: clicks wait longer
    browser_page.goto(studio_url)
    folder_title(browser_page, "Playback").wait_for(
        state="visible", timeout=RENDER_TIMEOUT_S * 1000
    )
    with contextlib.suppress(Exception):  # cosmetic: must never fail the test
        dismiss_software_webgl_warning(browser_page)
    return browser_page


def test_run_a_sweep_and_load_a_pareto_point(page, studio: Studio) -> None:
    session = studio.sweep
    expand_folder(page, SWEEP, "Run sweep")
    type_number(page, "Samples", 3)
    wait_for("3 samples received", lambda: session.panel.samples.value == 3, UI_TIMEOUT_S)
    click_button(page, "Run sweep")
    sweep = folder(page, SWEEP)
    sweep.get_by_text("Sweep done", exact=False).wait_for(
        state="visible", timeout=SWEEP_TIMEOUT_S * 1000
    )
    outcome = session.outcome
    assert outcome is not None and len(outcome.results) == 3 and outcome.pareto
    sweep.locator(".uplot canvas").first.wait_for(state="visible")
    solved = sum(r.solved for r in outcome.results)
    counts = f"3 / 3 done: {solved} solved, {3 - solved} failed, 0 cancelled"
    sweep.get_by_text(counts, exact=False).wait_for(state="visible")

    # a click on a point of the plot in the 3D view picks it
    target = next(r.index for r in outcome.results if r.index != session.picker.selected)
    (client,) = studio.web.server.get_clients().values()
    position = session.picker.board.world_position(target)
    assert position is not None
    click_button(page, "Pick on the plot in 3D")
    expected = session.picker.board.view(float(client.camera.fov), float(client.camera.aspect))
    wait_for(
        "the tab's camera on the plot",
        lambda: (
            np.allclose(client.camera.look_at, expected[1], atol=1e-3)
            and np.allclose(client.camera.position, expected[0], atol=1e-3)
        ),
        UI_TIMEOUT_S,
    )
    x, y = screen_point(client.camera, position, scene_canvas_box(page))
    picked: list[int] = []
    disconnect = session.picker.on_selected.connect(picked.append)
    try:
        page.mouse.click(x, y)
        sweep.get_by_text(f"Point #{target}", exact=False).first.wait_for(
            state="visible", timeout=UI_TIMEOUT_S * 1000
        )
    finally:
        disconnect()
    assert picked == [target] and session.panel.point.value == target

    best = outcome.pareto[0]
    type_number(page, "Point #", best)
    wait_for("the point number received", lambda: session.panel.point.value == best, UI_TIMEOUT_S)
    click_button(page, "Load point")
    sweep.get_by_text(f"Loaded point #{best}", exact=False).wait_for(
        state="visible", timeout=SWEEP_TIMEOUT_S * 1000
    )
    robot = studio.state.robot
    assert robot is not None and robot.name == "dircon_biped"
    motion = studio.state.motion
    assert motion is not None and f"sweep point #{best}" in motion.summary
