"""End to end in a real headless Chromium: the Simulation rows' *Balance feedback (IMU →
ankles/hips)* box. The page shows the feedback's gains; ticked, *Simulate* runs both runs with
it and again without it, and the verdicts in the page say both ("with balance feedback: stays
up · without: …"); unticked, the next simulation's verdicts no longer mention it, and are the
ones the first click gave without it."""

from __future__ import annotations

import re

from app.core.simulation.verdicts import short_text
from app.studio import Studio
from panels.simulation_panel import BALANCE_FEEDBACK
from tests.browser.page_helpers import (
    RENDER_TIMEOUT_S,
    UI_TIMEOUT_S,
    click_button,
    expand_folder,
    folder,
    generate_motion,
    gui_row_input,
    wait_for,
)

SIMULATION = "Simulation (MuJoCo)"


def shows(page, folder_label: str, pattern: str) -> str | None:
    """The folder's text when `pattern` (a regex) is in it."""
    text = folder(page, folder_label).inner_text()
    return text if re.search(pattern, text) else None


def _simulate(page, studio: Studio):
    before = studio.state.work.simulation
    click_button(page, "Simulate without / with compensation")
    return wait_for(
        "the simulation",
        lambda: (s := studio.state.work.simulation) is not None and s is not before and s,
        RENDER_TIMEOUT_S * 2,
    ).run


def _tick(page, studio: Studio, on: bool) -> None:
    box = gui_row_input(page, BALANCE_FEEDBACK, "input[type=checkbox]")
    box.scroll_into_view_if_needed()
    box.click()
    wait_for(
        f"the balance feedback {'on' if on else 'off'}",
        lambda: (studio.servo_rooms.simulation.balance is not None) == on,
        UI_TIMEOUT_S,
    )
    wait_for("the page's box", lambda: box.is_checked() == on, UI_TIMEOUT_S)


def test_the_balance_feedback_box_shows_its_gains_and_names_it_in_the_verdict(page, studio: Studio):
    generate_motion(page, studio, "com_shift")
    expand_folder(page, "Compensation", "Compute torque feed-forward")
    click_button(page, "Compute torque feed-forward")
    wait_for("the quick estimate", lambda: studio.state.work.prediction, RENDER_TIMEOUT_S)
    gains = wait_for(
        "the feedback's gains in the page",
        lambda: shows(page, SIMULATION, r"Balance feedback gains: ankles Kp [0-9.]+, Kd"),
        UI_TIMEOUT_S,
    )
    assert "hips Kp" in gains and "per joint" in gains

    _tick(page, studio, True)
    run = aided = _simulate(page, studio)
    text = wait_for(
        "the verdicts with and without the feedback in the page",
        lambda: shows(
            page, SIMULATION, r"with compensation: with balance feedback: stays up · without: "
        ),
        RENDER_TIMEOUT_S,
    )
    assert re.search(r"without compensation: \w[^\n]* with balance feedback", text), text
    for label, result in run.results.items():
        assert result.balance_feedback is not None and result.verdict() in text
        assert result.balance_offsets_rad is not None and result.balance_offsets_rad.any()
        alone = run.unaided[label]  # the same run without the feedback, in the same click
        assert alone.balance_feedback is None and alone.outcome is not None
        shown = f"{label}: with balance feedback: {short_text(result.outcome)} · without: "
        assert shown + short_text(alone.outcome) in text, text

    _tick(page, studio, False)
    run = _simulate(page, studio)
    text = wait_for(
        "the verdicts without the feedback in the page",
        lambda: (
            t
            if "with compensation: stays up" in (t := folder(page, SIMULATION).inner_text())
            and "balance feedback;" not in t
            and "with balance feedback" not in t
            else None
        ),
        RENDER_TIMEOUT_S,
    )
    assert all(result.balance_feedback is None for result in run.results.values()), text
    assert not run.unaided and " · without: " not in text
    for label, result in run.results.items():  # what the first click said without it
        assert result.verdict() == aided.unaided[label].verdict()
