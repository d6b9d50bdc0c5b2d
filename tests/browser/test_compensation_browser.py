"""End to end in a real headless Chromium: generate a one-leg motion, compute its torque
feed-forward, then edit one joint's compensation coefficient k and see the ghosts move.

Everything is done by clicking and typing in the page: the Motion and Joint dropdowns are
picked from their option lists, the playback time and k are typed into the number boxes
beside their sliders. The server's state is read to check what the page sent.

The page is loaded once for the module (software WebGL is slow) and each test continues from
the previous one: run them together, in file order.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from app.core.motions.library import MOTIONS
from app.core.simulation.mjcf import SimOptions
from app.studio import Studio
from tests.browser.page_helpers import (
    SIMULATE,
    UI_TIMEOUT_S,
    changed,
    click_button,
    compute_torques_in_page,
    expand_folder,
    folder,
    folder_title,
    gui_row_input,
    not_blank,
    page_time_s,
    publish,
    select_option,
    simulate_until_shown,
    type_number,
    wait_for,
    wait_stable,
)

MOTION = "one_leg_stand"
JOINT = "left_hip_roll"
"""The stance hip's roll: it carries the body's weight sideways while the right foot is up."""
MIN_TAU_NM = 0.5
"""|τ| of JOINT at the shown sample must exceed this for k·τ to show."""
TARGET_OFFSET_DEG = 20.0
"""How far the k edit moves JOINT's command at the shown sample (Δk ≈ this / |τ|)."""
# Fraction of the view that must change when the ghosts appear, and when two of them (the
# compensated command and the compensated prediction) turn by ~20° at the stance hip: 20x
# the noise allowed between two "stable" shots (STABLE_FRACTION). Measured with servo_biped:
# ~4.5 % and ~4 % of the view.
MIN_GHOSTS_FRACTION = 0.01
MIN_EDIT_FRACTION = 0.01


def single_support_time(studio: Studio) -> float:
    """The middle of the motion's longest stretch on one foot, on the 0.01 s timeline."""
    trajectory = studio.state.trajectory
    assert trajectory is not None
    single = trajectory.contacts[:, 0] != trajectory.contacts[:, 1]
    assert single.any(), f"{trajectory.name} never lifts a foot"
    samples = np.flatnonzero(single)
    return round(float(trajectory.t[samples[len(samples) // 2]]), 2)


@pytest.fixture(scope="module")
def shots() -> dict[str, np.ndarray]:
    """Screenshots shared by the module's tests."""
    return {}


def test_generate_a_motion_and_compute_its_torques(
    page, studio: Studio, shots: dict[str, np.ndarray], tmp_path: Path
) -> None:
    session = studio.state.work
    assert session.prediction is None and studio.servo_rooms.ghosts.view is None

    # Motions: pick the motion in the dropdown, wait for its parameters, generate it.
    expand_folder(page, "Motions", "Generate")
    select_option(page, "Motion", MOTION)
    wanted = {param.name for param in MOTIONS[MOTION].params}
    wait_for(
        f"the studio to show {MOTION}'s parameters",
        lambda: set(studio.motions.panel.inputs) == wanted,
        UI_TIMEOUT_S,
    )
    click_button(page, "Generate")
    trajectory = wait_for(
        f"the generated {MOTION}",
        lambda: (t := studio.state.trajectory) is not None and t.name == MOTION and t,
        UI_TIMEOUT_S,
    )

    # Playback: type a time when the right foot is up into the box beside "Time [s]".
    t_show = single_support_time(studio)
    type_number(page, "Time [s]", t_show)
    wait_for(
        f"the studio to seek to {t_show} s",
        lambda: studio.playback.panel.time.value == pytest.approx(t_show, abs=1e-9),
        UI_TIMEOUT_S,
    )
    assert page_time_s(page) == pytest.approx(t_show)
    plain = wait_stable(page, f"the robot at {t_show} s, without ghosts", not_blank)
    publish(page, "motion.png")

    # Compensation: compute τ (in a worker thread) and wait for the prediction.
    prediction = compute_torques_in_page(
        page, studio, "the prediction after the torque feed-forward"
    )
    feedforward = session.torques
    assert feedforward is not None
    # The ghosts session draws on the prediction's signal, after the prediction is stored.
    wait_for("the ghosts view", lambda: studio.servo_rooms.ghosts.view, UI_TIMEOUT_S)
    assert feedforward.tau_Nm.shape == (trajectory.n_samples, len(prediction.joint_names))
    folder(page, "Compensation").get_by_text("max |τ|", exact=False).wait_for(
        state="visible", timeout=UI_TIMEOUT_S * 1000
    )

    # The four translucent ghosts are drawn over the robot.
    with_ghosts = wait_stable(
        page,
        "the ghosts drawn",
        lambda image: changed(image, plain).mean() > MIN_GHOSTS_FRACTION,
    )
    fraction = float(changed(with_ghosts, plain).mean())
    assert fraction > MIN_GHOSTS_FRACTION, f"the ghosts changed only {fraction:.2%} of the view"
    Image.fromarray(with_ghosts.astype(np.uint8)).save(tmp_path / "ghosts.png")
    shots["ghosts"] = with_ghosts


def test_editing_k_moves_the_command_by_k_tau_without_recomputing(
    page, studio: Studio, shots: dict[str, np.ndarray], tmp_path: Path
) -> None:
    session, panel = studio.state.work, studio.servo_rooms.compensation.panel
    feedforward, before = session.torques, session.prediction
    trajectory = studio.state.trajectory
    assert feedforward is not None and before is not None and trajectory is not None, (
        "run with the previous test: it computes the torques edited here"
    )
    i = before.joint_names.index(JOINT)
    k_shown = trajectory.index_at(studio.playback.panel.time.value)
    tau = feedforward.tau_Nm[:, i]
    assert abs(tau[k_shown]) > MIN_TAU_NM, f"τ of {JOINT} is {tau[k_shown]:.3f} N·m there"

    # Pick the joint in the "Joint" dropdown.
    select_option(page, "Joint", JOINT)
    wait_for(
        f"the studio to select {JOINT}",
        lambda: panel.joint.value == JOINT,
        UI_TIMEOUT_S,
    )
    params = session.coefficients.params
    assert params.enabled[i], f"{JOINT} not compensated"
    assert panel.enabled.value is True
    k_before = float(params.k_deg_per_Nm[i])

    # Type a new k (the slider's step is 1 °/(N·m)) into the box beside the slider.
    k_after = float(round(k_before + TARGET_OFFSET_DEG / abs(tau[k_shown])))
    type_number(page, "k [°/(N·m)]", k_after)
    after = wait_for(
        f"the prediction with k = {k_after:g} °/(N·m) for {JOINT}",
        lambda: (
            (p := session.prediction) is not before
            and session.coefficients.params.k_deg_per_Nm[i] == k_after
            and p
        ),
        UI_TIMEOUT_S,
    )

    # The command of that joint moved by Δk·τ_drive (eq 7 on the drive torque τ + D·q̇ + J·q̈,
    # the studio's default: D = τ_max/ω_max of the joint's URDF limits, J the simulation's
    # armature), the others did not; τ was not recomputed.
    joint = studio.state.robot.joints[i]
    drive = (
        tau
        + joint.effort / joint.velocity * trajectory.v[:, joint.idx_v]
        + SimOptions().armature_kgm2 * trajectory.a[:, joint.idx_v]
    )
    delta = np.deg2rad(k_after - k_before)
    np.testing.assert_allclose(
        after.q_cmd_rad[:, i] - before.q_cmd_rad[:, i], delta * drive, rtol=0, atol=1e-9
    )
    others = np.arange(len(after.joint_names)) != i
    np.testing.assert_array_equal(after.q_cmd_rad[:, others], before.q_cmd_rad[:, others])
    assert session.torques is feedforward
    np.testing.assert_array_equal(after.tau_Nm, before.tau_Nm)
    assert panel.k.value == k_after

    # The page redrew the ghosts: the compensated command and prediction turn at the hip.
    moved = wait_stable(
        page,
        "the ghosts redrawn",
        lambda image: changed(image, shots["ghosts"]).mean() > MIN_EDIT_FRACTION,
    )
    fraction = float(changed(moved, shots["ghosts"]).mean())
    assert fraction > MIN_EDIT_FRACTION, f"the k edit changed only {fraction:.2%} of the view"
    Image.fromarray(moved.astype(np.uint8)).save(tmp_path / "ghosts_edited.png")


def test_plots_show_the_torques(page, studio: Studio) -> None:
    assert studio.servo_rooms.ghosts.plots.torques is not None, "run with the previous tests"
    plots = folder(page, "Plots")
    canvas = plots.locator(".uplot canvas")
    if not canvas.first.is_visible():
        folder_title(page, "Plots").click()
    canvas.first.wait_for(state="visible", timeout=UI_TIMEOUT_S * 1000)
    plots.get_by_text("Joint torque [N·m]", exact=True).wait_for(state="visible")
    assert plots.locator(".uplot").count() == 4  # torques, torso roll, torso pitch, offsets

    # The time cursor reaches the page: the charts' last column rises above its [0, 1] scale
    # at the time the studio shows.
    seek_to = float(studio.state.trajectory.t[studio.state.trajectory.n_samples // 3])
    studio.playback.seek(seek_to)
    wait_for(
        f"every chart's time cursor at {seek_to} s",
        lambda: page.evaluate(CURSOR_TIMES_JS) == [seek_to] * 4,
        UI_TIMEOUT_S,
    )

    # Hovering a plot shows viser's expand button; the dialog draws the plot much wider.
    small = plots.locator(".uplot").first.bounding_box()
    plots.locator(".uplot-container").first.hover()
    plots.locator(".uplot-container button").first.click()
    large = page.locator(".mantine-Modal-content .uplot")
    large.wait_for(state="visible", timeout=UI_TIMEOUT_S * 1000)
    assert large.bounding_box()["width"] > 1.8 * small["width"]  # viser's "xl" dialog
    page.keyboard.press("Escape")
    large.wait_for(state="detached", timeout=UI_TIMEOUT_S * 1000)

    # Wide plots: all four move into a window docked at the left, each over 500 px wide.
    gui_row_input(page, "Wide plots", "input[type=checkbox]").click()
    wait_for(
        "four plots over 500 px wide",
        lambda: len(widths := plot_widths(page)) == 4 and min(widths) > 500,
        UI_TIMEOUT_S,
    )
    gui_row_input(page, "Wide plots", "input[type=checkbox]").click()
    wait_for(
        "the plots back in the panel",
        lambda: plots.locator(".uplot").count() == 4,
        UI_TIMEOUT_S,
    )


def plot_widths(page) -> list[float]:
    """The widths [CSS px] of the page's plots now (one being replaced may have no box)."""
    return [box["width"] for u in page.locator(".uplot").all() if (box := u.bounding_box())]


CURSOR_TIMES_JS = """() => Object.values(window.__viserTestpoints?.uplots ?? {}).map(({chart}) => {
    const x = chart.data[0], cursor = chart.data[chart.data.length - 1];
    const i = Array.from(cursor).findIndex((v) => v > 1.0);
    return i < 0 ? null : x[i];
})"""
"""The time of each chart's cursor in the page (viser's uPlot testpoints), null without one."""


MIN_SIMULATED_GHOSTS_FRACTION = 0.002
"""The two simulated ghosts stand near the quick-estimate ghosts: a smaller change of the view
than the first ghosts, still 4x the noise allowed between two "stable" shots."""


def test_simulate_shows_the_verdicts_and_two_more_ghosts(
    page, studio: Studio, shots: dict[str, np.ndarray], tmp_path: Path
) -> None:
    session = studio.state.work
    assert session.prediction is not None, "run with the previous tests: they compute torques"
    expand_folder(page, "Compensation", SIMULATE)
    before = wait_stable(page, "the ghosts before simulating", not_blank)

    compensation = simulate_until_shown(page)
    assert session.simulation is not None
    simulation = session.simulation.run
    assert simulation.error == ""
    for label, run in simulation.results.items():
        line = compensation.get_by_text(f"{label}: {run.verdict()}", exact=False)
        assert line.count() >= 1, f"the page does not show the verdict of {label}"

    # The page draws the two simulated ghosts.
    after = wait_stable(
        page,
        "the simulated ghosts drawn",
        lambda image: (
            not_blank(image) and changed(image, before).mean() > MIN_SIMULATED_GHOSTS_FRACTION
        ),
    )
    fraction = float(changed(after, before).mean())
    assert fraction > MIN_SIMULATED_GHOSTS_FRACTION, f"only {fraction:.2%} of the view changed"
    Image.fromarray(after.astype(np.uint8)).save(tmp_path / "simulated.png")
    publish(page, "compensation.png")


def test_the_page_answers_clicks_while_the_ghosts_play(page, studio: Studio) -> None:
    """Playback with the robot, four ghosts, two simulated ghosts and the plots' cursor moving:
    the page still answers a click (Pause), and stops where the studio stopped. The waits are
    printed for the log (a software renderer on a busy machine sets them), not asserted."""
    assert studio.state.work.simulation is not None, "run with the previous tests"
    expand_folder(page, "Playback", "Play")
    started = time.monotonic()
    click_button(page, "Play")
    wait_for("the player to start", lambda: studio.playback.player.playing, UI_TIMEOUT_S)
    page.get_by_role("button", name="Pause").first.wait_for(
        state="visible", timeout=UI_TIMEOUT_S * 1000
    )
    print(f"Play: shown {time.monotonic() - started:.1f} s after the click")
    # Let the animation run until the page has drawn a few different frames.
    first = page_time_s(page)
    wait_for("the page's time to move", lambda: page_time_s(page) != first, UI_TIMEOUT_S)
    started = time.monotonic()
    click_button(page, "Pause")
    wait_for("the player to stop", lambda: not studio.playback.player.playing, UI_TIMEOUT_S)
    page.get_by_role("button", name="Play").first.wait_for(
        state="visible", timeout=UI_TIMEOUT_S * 1000
    )
    print(f"Pause during playback: shown {time.monotonic() - started:.1f} s after the click")
    stopped_at = studio.state.time_s
    wait_for(
        "the page's time to show where the studio stopped",
        lambda: page_time_s(page) == pytest.approx(stopped_at, abs=0.006),
        UI_TIMEOUT_S,
    )
