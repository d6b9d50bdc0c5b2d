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
    compute_torques_in_page,
    folder,
    folder_shows,
    generate_motion,
    gui_row_input,
    simulate_in_page,
    wait_for,
)

SIMULATION = "Simulation (MuJoCo)"


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
    compute_torques_in_page(page, studio)
    gains = wait_for(
        "the feedback's gains in the page",
        lambda: folder_shows(page, SIMULATION, r"Balance feedback gains: ankles Kp [0-9.]+, Kd"),
        UI_TIMEOUT_S,
    )
    assert "hips Kp" in gains and "per joint" in gains

    _tick(page, studio, True)
    run = aided = simulate_in_page(page, studio)
    text = wait_for(
        "the verdicts with and without the feedback in the page",
        lambda: folder_shows(
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
    run = simulate_in_page(page, studio)
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
