"""End to end in a real headless Chromium: solve a gait for the loaded robot (servo_biped) from
the "Gait (DIRCON)" folder, watch its progress and results in the page, walk it with footprints,
then start a larger solve and cancel it.

Everything is done by clicking and typing in the page; the server's state is read to check what
the page sent and what the solver returned. A solve of the default gait (38 knots) takes a few
seconds, so its "Solving…" status may be on screen for less than a poll of Playwright: a
MutationObserver installed in the page records when each status text first appears (on the
page's clock), which also gives the cancel latency as the page sees it (click → "Cancelled").

The page is loaded once for the module (software WebGL is slow) and each test continues from
the previous one: run them together, in file order.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from app.studio import Studio
from tests.browser.page_helpers import (
    RENDER_TIMEOUT_S,
    UI_TIMEOUT_S,
    changed,
    chart_pixels,
    click_button,
    dismiss_software_webgl_warning,
    expand_folder,
    folder,
    folder_title,
    not_blank,
    publish,
    type_number,
    wait_for,
    wait_stable,
)

GAIT = "Gait (DIRCON)"
SOLVE_TIMEOUT_S = 180.0
"""A first solve: spawn the worker, build the 38-knot NLP, run IPOPT (a few seconds here)."""
WALK_STEPS = 4
"""The panel's default number of steps to walk."""
BIG_KNOTS = 160
"""The finest mesh the panel offers: a new NLP structure the worker builds, then a refined solve
(~15 s of CPU here, more on a busy machine), so the Cancel a second or two after Solve lands
while it runs. At 80 knots (~4 s) a busy CI machine once let the solve finish before the click."""
# Fraction of the view that must change when the walk's footprints appear on the floor:
# 10x the noise allowed between two "stable" shots.
MIN_FOOTPRINTS_CHANGE_FRACTION = 0.005
NEW_STRUCTURE_KNOTS = 150
"""A mesh no earlier test built: its solve first spends seconds building the NLP (and a coarse
solve), so a Cancel right after "Solving…" shows lands before IPOPT's first iteration."""
MARKERS = ("Solving", "Solved in", "Cancelled")

# Records, on the page's clock (performance.now(), ms), when each marker text appears in the
# page (absent -> present) and when the Cancel button is clicked.
RECORDER_JS = """
(markers) => {
  const rec = { events: [], cancelClicks: [] };
  window.__gaitRecorder = rec;
  const present = {};
  const check = () => {
    const text = document.body.textContent || "";
    for (const marker of markers) {
      const now = text.includes(marker);
      if (now && !present[marker]) rec.events.push({ marker, t: performance.now() });
      present[marker] = now;
    }
  };
  check();
  new MutationObserver(check).observe(document.body, {
    subtree: true, childList: true, characterData: true,
  });
  document.addEventListener("click", (event) => {
    const button = event.target.closest && event.target.closest("button");
    if (button && button.textContent.trim() === "Cancel") rec.cancelClicks.push(performance.now());
  }, true);
}
"""


# The second tab's record (page clock, ms): when "Solving the symmetric gait" first shows, and
# when its Cancel button is first on while Solve is off (the buttons of a solve under way).
WATCHER_JS = """
() => {
  const rec = { solving: null, busy: null };
  window.__gaitWatcher = rec;
  const button = (name) =>
    [...document.querySelectorAll("button")].find((b) => b.textContent.trim() === name);
  const check = () => {
    const text = document.body.textContent || "";
    if (rec.solving === null && text.includes("Solving the symmetric gait")) {
      rec.solving = performance.now();
    }
    const cancel = button("Cancel"), solve = button("Solve");
    if (rec.busy === null && cancel && solve && !cancel.disabled && solve.disabled) {
      rec.busy = performance.now();
    }
  };
  check();
  new MutationObserver(check).observe(document.body, {
    subtree: true, childList: true, characterData: true, attributes: true,
  });
}
"""


def recorded(page) -> dict:
    return page.evaluate("() => window.__gaitRecorder")


def seen_at(page, marker: str, after_ms: float = -1.0) -> float | None:
    """When `marker` last appeared in the page after `after_ms` (page clock, ms), if it did."""
    times = [e["t"] for e in recorded(page)["events"] if e["marker"] == marker]
    later = [t for t in times if t > after_ms]
    return later[-1] if later else None


def page_now_ms(page) -> float:
    return float(page.evaluate("() => performance.now()"))


def click_solve(page) -> float:
    """Click *Solve* and wait for the page to show "Solving…"; when it was clicked (page ms)."""
    clicked_ms = page_now_ms(page)
    click_button(page, "Solve")
    wait_for(
        'the page to show "Solving…"',
        lambda: seen_at(page, "Solving", clicked_ms) is not None,
        UI_TIMEOUT_S,
    )
    return clicked_ms


@pytest.fixture(scope="module")
def page(page):
    """The studio page (tests/browser/conftest.py) with the status recorder installed."""
    page.evaluate(RECORDER_JS, list(MARKERS))
    return page


def test_solve_shows_progress_then_results(page, studio: Studio) -> None:
    session = studio.gait
    assert session.solves.running is None and session.results.symmetric is None
    expand_folder(page, GAIT, "Solve")
    gait = folder(page, GAIT)
    assert not page.get_by_role("button", name="Walk this gait", exact=True).is_enabled()

    # Progress: the status says "Solving…", then IPOPT's iterations arrive (the convergence
    # chart is added at the first one; the progress bar shows while the solve runs).
    clicked_ms = click_solve(page)
    gait.locator(".uplot canvas").first.or_(gait.locator(".mantine-Progress-root")).first.wait_for(
        state="visible", timeout=SOLVE_TIMEOUT_S * 1000
    )

    # Solved: the status and the results beside the paper's Table 4.
    gait.get_by_text("Solved in", exact=False).wait_for(
        state="visible", timeout=SOLVE_TIMEOUT_S * 1000
    )
    gait.get_by_text("9.8 / 11.5", exact=True).wait_for(state="visible")  # Table 4 beside ours
    gait.locator(".uplot canvas").first.wait_for(state="visible")
    gait.get_by_text("IPOPT convergence", exact=True).wait_for(state="visible")
    assert seen_at(page, "Solving", clicked_ms) < seen_at(page, "Solved in", clicked_ms)

    assert session.solves.running is None
    result = session.results.symmetric
    assert result.converged
    assert len(session.solves.history[0]) >= 1  # convergence was reported live
    print(f"\nsolve: {result.iterations} IPOPT iterations, {result.solve_s:.2f} s in the worker")


def test_walk_this_gait_on_the_loaded_robot(page, studio: Studio, tmp_path: Path) -> None:
    assert studio.gait.results.symmetric is not None, "run with the previous test: it solves"
    robot = studio.state.robot
    assert robot is not None and robot.name == "servo_biped"
    before = wait_stable(page, f"{robot.name} drawn", not_blank)

    click_button(page, "Walk this gait")  # enabled once a gait is solved
    trajectory = wait_for(
        "the walk sent to playback",
        lambda: (t := studio.state.trajectory) is not None and t,
        UI_TIMEOUT_S,
    )
    assert studio.state.robot is robot  # the walk is the loaded robot's
    assert trajectory.contacts[0].all() and trajectory.contacts[-1].all()  # standing to standing
    walk = studio.gait.walk
    assert walk is not None and len(walk.footprints) == WALK_STEPS + 2
    # The walk starts playing; pause it (as a user would) to compare still pictures.
    wait_for("the walk playing", lambda: studio.playback.player.playing, UI_TIMEOUT_S)
    # The Playback folder is open by default; wait for the relabelled button (clicking the
    # folder's title before the label arrives would fold the folder away).
    page.get_by_role("button", name="Pause", exact=True).wait_for(
        state="visible", timeout=UI_TIMEOUT_S * 1000
    )
    click_button(page, "Pause")
    wait_for("the walk paused", lambda: not studio.playback.player.playing, UI_TIMEOUT_S)

    # The page draws the footprints on the floor.
    after = wait_stable(
        page,
        "footprints drawn",
        lambda image: (
            not_blank(image) and changed(image, before).mean() > MIN_FOOTPRINTS_CHANGE_FRACTION
        ),
    )
    fraction = float(changed(after, before).mean())
    assert fraction > MIN_FOOTPRINTS_CHANGE_FRACTION, f"only {fraction:.2%} of the view changed"
    Image.fromarray(after.astype(np.uint8)).save(tmp_path / "walk.png")
    publish(page, "walk.png")


def test_cancel_a_larger_solve_keeps_the_last_good_gait(page, studio: Studio, studio_url) -> None:
    """...seen from a second tab too: it shows the solve another tab started (its live status,
    Cancel on, Solve off) and its end."""
    session = studio.gait
    good = session.results.symmetric
    assert good is not None, "run with the previous tests: they solve the gait kept here"
    other = page.context.new_page()
    other.goto(studio_url)
    folder_title(other, "Playback").wait_for(state="visible", timeout=RENDER_TIMEOUT_S * 1000)
    dismiss_software_webgl_warning(other)
    expand_folder(other, GAIT, "Cancel")

    type_knots(page, session, BIG_KNOTS)

    # What the second tab shows while the solve runs is recorded in that tab as it happens:
    # waiting on it before the Cancel let a fast machine finish the solve first (~7 CPU-s).
    other.evaluate(WATCHER_JS)
    clicked_ms = solve_then_cancel(page)
    assert session.solves.running is None or session.solves.running.settings.knots == BIG_KNOTS
    assert seen_at(page, "Solved in", clicked_ms) is None, (
        f"the {BIG_KNOTS}-knot solve finished before the Cancel reached the studio"
    )
    rec = recorded(page)
    assert rec["cancelClicks"], "the page did not see the click on Cancel"
    cancelled_ms = seen_at(page, "Cancelled", clicked_ms)
    assert cancelled_ms is not None
    before = [ms for ms in rec["cancelClicks"] if ms < cancelled_ms]
    assert before, "the page showed Cancelled before any click on Cancel"
    click_ms = before[0]  # the first click the enabled button took
    # Measured, not asserted (a busy machine only makes it slower): SIGTERM, SIGKILL after 0.5 s.
    latency_s = (cancelled_ms - click_ms) / 1000.0
    print(f"\ncancel latency seen in the page (click → 'Cancelled'): {latency_s:.3f} s")

    folder(other, GAIT).get_by_text("Cancelled", exact=False).wait_for(
        state="visible", timeout=UI_TIMEOUT_S * 1000
    )
    watched = other.evaluate("() => window.__gaitWatcher")
    assert watched["solving"] is not None, "the other tab never showed the solve under way"
    assert watched["busy"] is not None, "the other tab never showed Cancel on and Solve off"
    other.close()
    wait_for("the studio to be idle", lambda: session.solves.running is None, UI_TIMEOUT_S)
    assert session.results.symmetric is good
    assert not page.get_by_role("button", name="Cancel", exact=True).is_enabled()


SERIES_RGB = ((0x1F, 0x77, 0xB4), (0xD6, 0x27, 0x28))
"""The convergence chart's two strokes (objective, violation), as GaitPanel draws them."""
MIN_STROKE_PIXELS = 30
"""Pixels of a series' colour that make a drawn line across the chart (a line over the 5-30
iterations of a warm or cold solve is hundreds of pixels long; an empty chart has none)."""


def test_convergence_chart_draws_again_after_a_cancel_before_any_iteration(
    page, studio: Studio
) -> None:
    """A solve cancelled while the worker still builds its NLP ends with no iteration; the next
    solve's convergence must still be drawn in the page (it stayed blank until a reload)."""
    session = studio.gait
    expand_folder(page, GAIT, "Solve")
    # a structure new to the worker, cancelled as soon as it can be: built from the disk cache
    # it may still reach IPOPT first (then the next knot count is tried)
    for knots in range(NEW_STRUCTURE_KNOTS, NEW_STRUCTURE_KNOTS - 3, -1):
        type_knots(page, session, knots)
        solve_then_cancel(page)
        wait_for("the studio to be idle", lambda: session.solves.running is None, UI_TIMEOUT_S)
        if session.solves.history == ([], [], []):
            break
    assert session.solves.history == ([], [], []), (
        "each solve reached IPOPT before the Cancel: this test needs a cancel during the NLP build"
    )

    type_number(page, "knots", 38)
    wait_for(
        "the studio to receive 38 knots",
        lambda: session.panel.sliders["knots"].value == 38,
        UI_TIMEOUT_S,
    )
    clicked_ms = click_solve(page)
    wait_for(
        'the page to show "Solved in"',
        lambda: seen_at(page, "Solved in", clicked_ms) is not None,
        SOLVE_TIMEOUT_S,
    )
    assert len(session.solves.history[0]) >= 2
    drawn = wait_for(
        "the convergence chart to draw both series",
        lambda: (
            (counts := chart_pixels(page, GAIT, SERIES_RGB))
            and min(counts) >= MIN_STROKE_PIXELS
            and counts
        ),
        UI_TIMEOUT_S,
    )
    print(f"\nconvergence chart: {drawn} pixels of the objective / violation strokes")


def solve_then_cancel(page) -> float:
    """Click *Solve*, then *Cancel* as a quick hand does, again until the page says the solve
    ended (cancelled, or solved first); when Solve was clicked (page ms). On this machine the
    160-knot solve takes ~3.5 s from warm caches: a click that first waits for the button to
    be scrolled to and stable (Playwright's) came after it."""
    cancel = page.get_by_role("button", name="Cancel", exact=True)
    cancel.scroll_into_view_if_needed()
    box = cancel.bounding_box()
    assert box is not None
    clicked_ms = click_solve(page)

    def ended() -> bool:
        if any(seen_at(page, m, clicked_ms) is not None for m in ("Cancelled", "Solved in")):
            return True
        page.mouse.click(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
        return False

    wait_for('the page to show "Cancelled" (or the solve\'s end)', ended, UI_TIMEOUT_S)
    return clicked_ms


def type_knots(page, session, knots: int) -> None:
    """Type `knots` into the box beside the "knots" slider, until the studio has them."""
    type_number(page, "knots", knots)
    wait_for(
        f"the studio to receive {knots} knots",
        lambda: session.panel.sliders["knots"].value == knots,
        UI_TIMEOUT_S,
    )
