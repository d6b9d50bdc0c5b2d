"""End to end in a real headless Chromium: run a small sweep from the "Sweep" folder, see the
counts and the Pareto plot drawn, turn the camera to the plot in the 3D view and click a point
on it (the panel shows the point picked), then type a point of the front and load it (its robot
and a walk of its gait). Then the servo parts, by the page: the user's own servo file uploaded
in the Servos folder joins the Sweep folder's part:servo choices, whose rows, simulation switch
and the parts' Pareto axes set on the page reach the studio's sweep; the file removed in the
Servos folder puts the joint on its servo back on the ideal servo, and Undo brings it back.

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
    chart_pixels,
    click_button,
    dismiss_software_webgl_warning,
    expand_folder,
    folder,
    folder_title,
    gui_row_input,
    pause_playback,
    scene_canvas_box,
    screen_point,
    select_option,
    type_number,
    wait_for,
    wait_notified,
)

SWEEP = "Sweep"
FRONT_RGB = (0xD6, 0x27, 0x28)
"""The Pareto front's colour in the panel's chart (panels.sweep_panel.FRONT_COLOUR)."""
MIN_CHART_PIXELS = 20
"""A drawn point of the front (8 px across) covers about 50 pixels; an empty chart none."""
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
    # The panel's chart draws the Pareto front (it drew nothing while a series held a gap).
    wait_for(
        "the panel's chart to draw the Pareto front",
        lambda: chart_pixels(page, SWEEP, (FRONT_RGB,))[0] >= MIN_CHART_PIXELS,
        UI_TIMEOUT_S,
    )
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


def test_a_users_servo_file_in_a_sweep_over_parts_and_removed(page, studio: Studio) -> None:
    from app.core.servo.catalogue import load_catalogue
    from app.core.servo.choice import simulatable
    from app.core.sweeps.spec import SweepSpec
    from tests.browser.test_servos_browser import upload
    from tests.test_sweep_part_axes import user_mx106

    pause_playback(page)  # the point loaded above plays its walk on a loop
    expand_folder(page, "Servos", "Add servo file (.toml)")
    servos = folder(page, "Servos")
    upload(page, "mine.toml", user_mx106())
    servos.get_by_text("Added 1 servo(s) from mine.toml", exact=False).wait_for(
        state="visible", timeout=UI_TIMEOUT_S * 1000
    )
    keys = sorted([*simulatable(load_catalogue()), "my106"])
    at = keys.index("my106")

    # the Sweep folder: the user's servo among part:servo's choices, set from the page
    expand_folder(page, SWEEP, "Run sweep")
    sweep = folder(page, SWEEP)
    sweep.get_by_text(f"{at} my106", exact=False).wait_for(
        state="visible", timeout=UI_TIMEOUT_S * 1000
    )
    select_option(page, "Parameter 1", "part:servo")
    type_number(page, "1: min", at - 1)
    type_number(page, "1: max", at)
    select_option(page, "Parameter 2", "part:kp")
    type_number(page, "2: min", 16)
    type_number(page, "2: max", 48)
    if not studio.sweep.panel.simulate.value:
        gui_row_input(page, "Simulate each point", "input[type=checkbox]").click()
    select_option(page, "Metric x", "servo_mass_kg")
    select_option(page, "Metric y", "electrical_energy_J")

    def spec() -> SweepSpec | None:
        try:
            return SweepSpec.from_mapping(studio.sweep.panel_sweep())
        except Exception:  # the page's rows still on their way
            return None

    swept = wait_for(
        "the page's parts sweep in the studio",
        lambda: (
            (s := spec()) is not None
            and s.parameters[0].choices == (keys[at - 1], "my106")
            and (s.parameters[1].minimum, s.parameters[1].maximum) == (16.0, 48.0)
            and s.pareto == (("servo_mass_kg", "min"), ("electrical_energy_J", "min"))
            and s
        ),
        UI_TIMEOUT_S,
    )
    assert swept.simulate and [f.name for f in swept.user_servos] == ["mine.toml"]

    # the user's servo on a joint, then its file removed: the joint back on the ideal servo
    joint = studio.state.robot.joint_names[0]
    select_option(page, "Servo of joint", joint)
    select_option(page, "Servo", "my106 — ROBOTIS Dynamixel MX-106T/R")
    wait_for(
        f"my106 on {joint}",
        lambda: (p := studio.state.work.parts) is not None and p.joint(joint).servo == "my106",
        UI_TIMEOUT_S,
    )
    history = studio.project.undo_steps.history
    wait_for(
        "my106 on the joint to be an undo step",
        lambda: history.past and history.past[-1].servo_parts is studio.state.work.parts,
        UI_TIMEOUT_S,
    )
    select_option(page, "Servo file", "mine.toml")
    click_button(page, "Remove servo file")
    wait_notified(page, "Servo file removed", f"back on the ideal servo: {joint}", UI_TIMEOUT_S)
    parts = studio.state.work.parts
    assert parts.joint(joint).is_ideal and not parts.user_servos
    sweep.get_by_text(f"{at} my106", exact=False).wait_for(
        state="hidden", timeout=UI_TIMEOUT_S * 1000
    )

    wait_for(
        "the removal to be an undo step",
        lambda: history.past[-1].servo_parts is studio.state.work.parts,
        UI_TIMEOUT_S,
    )
    expand_folder(page, "Project", "Undo")
    click_button(page, "Undo")
    wait_notified(page, "Undid: servo file mine.toml removed", "", UI_TIMEOUT_S)
    parts = wait_for(
        "Undo to put the file and the joint's servo back",
        lambda: (
            (p := studio.state.work.parts) is not None and p.joint(joint).servo == "my106" and p
        ),
        UI_TIMEOUT_S,
    )
    assert [f.name for f in parts.user_servos] == ["mine.toml"]
