"""The README's tour in one Chromium tab, as a user clicks it (issue 23): drag the pelvis and
Undo; generate a motion, compute its torques, pick the paper's Table 3 preset, simulate; solve
a gait, move a slider and solve again warm; the one click, watched in the page; export a
replay from the tab and play it from a static web server.

The tour's other stops have their own modules, each walked the same way: every load path
(test_load_browser), the foot drag (test_foot_drag_browser), a sweep and a click on its Pareto
board (test_sweep_browser), Save as / reload / Open (test_project_browser), Undo's words and
the restart (test_session_ux_browser), the screenshot download (test_replay_browser).

The page is loaded once for the module and each test continues from the previous one: run
them together, in file order. The studio's log must stay free of tracebacks (tests/conftest.py
fails a test during which one is logged). Waits that a user would feel are printed.
"""

from __future__ import annotations

import re
import time
from pathlib import Path

import numpy as np
import pytest

from app.core.servo.presets import PRESETS
from app.studio import Studio
from tests.browser.conftest import VIEWPORT
from tests.browser.page_helpers import (
    RENDER_TIMEOUT_S,
    UI_TIMEOUT_S,
    click_button,
    compute_torques_in_page,
    expand_folder,
    folder,
    generate_motion,
    not_blank,
    pause_playback,
    record_texts,
    scene_canvas_box,
    screen_point,
    select_option,
    simulate_until_shown,
    static_server,
    studio_context,
    texts_seen,
    type_number,
    wait_for,
    wait_notified,
    wait_stable,
)
from tests.browser.test_replay_browser import wait_until_playing

MOTION = "com_shift"
PAPER_TABLE3_K = {2: -4.0, 3: -650.0, 8: 20.0, 9: -1200.0}
"""The spring-compensation paper's Table 3 (servo number: k [°/(N·m)]), typed from the paper."""
GAIT = "Gait (DIRCON)"
SOLVE_TIMEOUT_S = 300.0
ONE_CLICK = "Plan → walk → torques → simulate"
ONE_CLICK_TIMEOUT_S = 600.0
"""Walk, the walk's torques on every sample, two MuJoCo runs: minutes on a busy machine."""
PELVIS_DRAG_PX = 30
ON_ARROW = 0.7
"""Where along the pelvis gizmo's z arrow the mouse takes it (a fraction of its scale)."""

STAGE_MARKERS = ("stage 2 of 4", "stage 3 of 4", "stage 4 of 4", "One click ✅")


@pytest.fixture(scope="module")
def page(page):
    """The studio page (tests/browser/conftest.py), recording when each stage line shows."""
    record_texts(page, "stages", STAGE_MARKERS)
    return page


def test_drag_the_pelvis_down_then_undo(page, studio: Studio) -> None:
    robot = studio.state.robot
    assert robot is not None and studio.pose.handles is not None
    wait_stable(page, "the studio's first render", not_blank)
    (client,) = studio.web.server.get_clients().values()
    # From straight legs the pelvis cannot go down: bend the knees first, as docs/pose.md says.
    q_straight = studio.state.q.copy()
    expand_folder(page, "Pose (drag the feet)", "Ready pose (knees bent)")
    click_button(page, "Ready pose (knees bent)")
    wait_for(
        "the ready pose",
        lambda: not np.allclose(studio.state.q, q_straight) and studio.state.q.copy(),
        UI_TIMEOUT_S,
    )
    q_before = studio.state.q.copy()
    history = studio.project.undo_steps.history
    # Undo steps are still moments (a pause in the work): wait for the ready pose to be one.
    wait_for(
        "the ready pose to be an undo step",
        lambda: history.past and np.array_equal(history.past[-1].pose.q, q_before),
        UI_TIMEOUT_S,
    )
    data = robot.model.createData()
    root = robot.tree.root
    feet = [studio.pose.handles.frames[side] for side in ("left", "right")]
    before = robot.link_placements(q_before, data)
    pelvis = before[root][:3, 3].copy()
    soles = [before[foot][:3, 3].copy() for foot in feet]

    scale = float(studio.pose.handles.handle("pelvis").scale)
    grab = screen_point(
        client.camera, pelvis + np.array([0.0, 0.0, ON_ARROW * scale]), scene_canvas_box(page)
    )
    page.mouse.move(*grab)
    page.mouse.down()
    for k in range(1, 11):
        page.mouse.move(grab[0], grab[1] + PELVIS_DRAG_PX * k / 10)
    page.mouse.up()
    wait_for(
        "the pelvis drag to reach the studio",
        lambda: (pose := studio.state.pose) is not None and pose.origin == "drag:pelvis",
        UI_TIMEOUT_S,
    )
    after = robot.link_placements(studio.state.q, data)
    assert after[root][2, 3] < pelvis[2] - 0.005, "the pelvis did not go down"
    for foot, sole in zip(feet, soles, strict=True):  # both feet stay where they stood
        assert np.linalg.norm(after[foot][:3, 3] - sole) < 1e-3

    wait_for(
        "the drag to be an undo step",
        lambda: history.past[-1].pose.origin == "drag:pelvis",
        UI_TIMEOUT_S,
    )
    expand_folder(page, "Project", "Undo")
    click_button(page, "Undo")
    wait_for(
        "Undo to put the pose back",
        lambda: np.allclose(studio.state.q, q_before, atol=1e-9),
        UI_TIMEOUT_S,
    )
    wait_notified(page, "Undid: pelvis drag", "", UI_TIMEOUT_S)


def test_torques_then_the_paper_table3_preset_then_simulate(page, studio: Studio) -> None:
    work = studio.state.work
    generate_motion(page, studio, MOTION)
    compute_torques_in_page(page, studio, "the torques and the prediction")

    select_option(page, "Preset", PRESETS["table3"].label)
    params = wait_for(
        "the Table 3 preset in the studio",
        lambda: (c := work.coefficients) is not None and c.params.enabled.sum() == 4 and c.params,
        UI_TIMEOUT_S,
    )
    # Table 3's four servos, possibly scaled down together to keep the commands within the
    # joint limits: the same ratios as the paper's numbers, in the paper's servo order.
    k = params.k_deg_per_Nm[params.enabled]
    paper = np.array(list(PAPER_TABLE3_K.values()))
    assert sorted(k / np.max(np.abs(k))) == pytest.approx(sorted(paper / np.max(np.abs(paper))))

    started = time.monotonic()
    compensation = simulate_until_shown(page)
    print(f"Simulate: verdict shown {time.monotonic() - started:.1f} s after the click")
    record = work.simulation
    assert record is not None
    simulation = record.run
    assert simulation.error == ""
    for label, run in simulation.results.items():
        assert compensation.get_by_text(f"{label}: {run.verdict()}", exact=False).count() >= 1
    # Back to the uniform preset for the walk ahead: Table 3's k (up to 1 200 °/(N·m)) would
    # push a walk's commands past the joint limits (the one click then stops and says so).
    # The simulated motion plays on a loop: paused first, as a user does before editing
    # (clicks while it plays: tests/browser/test_compensation_browser.py).
    pause_playback(page)
    select_option(page, "Preset", PRESETS["uniform"].label)
    wait_for(
        "the uniform preset in the studio",
        lambda: (c := work.coefficients) is not None and c.params.enabled.sum() > 4,
        UI_TIMEOUT_S,
    )


def solve_in_page(page, studio: Studio, previous, shows: str, what: str):
    """Click Solve, wait for a new gait in the studio and for `shows` in the Gait folder; the
    gait. The wait the user felt is printed."""
    gait = studio.gait
    started = time.monotonic()
    click_button(page, "Solve")
    result = wait_for(
        what,
        lambda: (r := gait.results.symmetric) is not previous and gait.solves.running is None and r,
        SOLVE_TIMEOUT_S,
    )
    folder(page, GAIT).get_by_text(shows, exact=False).first.wait_for(
        state="visible", timeout=UI_TIMEOUT_S * 1000
    )
    print(f"{what}: shown {time.monotonic() - started:.1f} s after the click")
    return result


def test_solve_a_gait_move_a_slider_and_solve_again_warm(page, studio: Studio) -> None:
    gait = studio.gait
    expand_folder(page, GAIT, "Solve")
    first = solve_in_page(page, studio, None, "Solved in", "the first (cold) solve")
    assert first.converged

    k0 = round(float(gait.panel.sliders["K0"].value) - 0.5, 1)
    type_number(page, "K0 energy", k0)
    wait_for("the studio to take K0", lambda: gait.panel.sliders["K0"].value == k0, UI_TIMEOUT_S)
    second = solve_in_page(
        page, studio, first, "warm start from the last gait", "the warm re-solve"
    )
    assert second.converged
    assert pytest.approx(k0) == second.settings.K0
    # Warm from a neighbouring optimum: fewer IPOPT iterations than the cold solve took.
    assert second.iterations < first.iterations


def test_the_one_click_walks_computes_and_simulates_in_the_page(page, studio: Studio) -> None:
    gait = studio.gait
    assert gait.results.symmetric is not None, "run with the previous test: it solves"
    clicked = float(page.evaluate("() => performance.now()"))
    started = time.monotonic()
    click_button(page, ONE_CLICK)
    folder(page, GAIT).get_by_text("One click ✅", exact=False).first.wait_for(
        state="visible", timeout=ONE_CLICK_TIMEOUT_S * 1000
    )
    print(f"One click: done in the page {time.monotonic() - started:.1f} s after the click")
    seen = {marker: t for marker, t in texts_seen(page, "stages") if t >= clicked}
    # The sliders still fit the last gait: the one click starts at the walk (stage 2). The page
    # may draw two quick stages in one render, so a stage can be missing from the record; the
    # ones it shows must come in order, before the end.
    shown = [t for marker in STAGE_MARKERS if (t := seen.get(marker)) is not None]
    assert "One click ✅" in seen, f"the page never showed the end: {seen}"
    assert len(shown) >= 2, f"the page showed no stage before the end: {seen}"
    assert shown == sorted(shown), f"the stages appeared out of order: {seen}"
    trajectory = studio.state.trajectory
    record = studio.state.work.simulation
    assert trajectory is not None and gait.walk is not None
    assert trajectory is gait.walk.trajectory
    assert record is not None and record.run.trajectory is trajectory


def test_export_a_replay_from_the_tab_and_play_it_from_a_static_server(
    page, studio: Studio, chromium
) -> None:
    pause_playback(page)  # the one click's simulated walk plays on a loop
    expand_folder(page, "Share", "Export replay")
    click_button(page, "Export replay")
    share = folder(page, "Share")
    status = share.get_by_text("Replay of", exact=False).first
    status.wait_for(state="visible", timeout=RENDER_TIMEOUT_S * 1000)
    match = re.search(r"in (/\S+?)\.\s", status.inner_text() + " ")
    assert match is not None, status.inner_text()
    replay = Path(match.group(1))
    assert (replay / "index.html").is_file()

    context = studio_context(chromium, viewport=VIEWPORT)
    viewer = context.new_page()
    try:
        with static_server(replay) as url:
            viewer.goto(url)
            wait_until_playing(viewer)
    finally:
        context.close()
