"""End to end in a real headless Chromium: run a small sweep from the "Sweep" folder, see the
Pareto plot drawn, type a point of the front and load it (its robot and a walk of its gait).

The page is loaded once for the module (software WebGL is slow)."""

from __future__ import annotations

import pytest

from app.studio import Studio
from tests.browser.page_helpers import (
    RENDER_TIMEOUT_S,
    UI_TIMEOUT_S,
    click_button,
    expand_folder,
    folder,
    folder_title,
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
    browser_page.goto(studio_url)
    folder_title(browser_page, "Playback").wait_for(
        state="visible", timeout=RENDER_TIMEOUT_S * 1000
    )
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
