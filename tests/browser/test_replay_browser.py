"""An exported replay plays in a real headless Chromium from a plain static web server
(`python -m http.server` in a subprocess), with no studio running and nothing else fetched."""

from __future__ import annotations

import io
import re
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from app.core.replay.pipeline import headless_scene
from app.core.robot.loading import load_robot
from app.core.servo.presets import preset_params
from app.core.simulation.files import default_servos
from app.replay_recorder import export_replay
from tests.browser.conftest import VIEWPORT
from tests.browser.page_helpers import (
    RENDER_TIMEOUT_S,
    UI_TIMEOUT_S,
    changed,
    not_blank,
    static_server,
    studio_context,
    wait_for,
)

SCENE_CLIP = {"x": 0, "y": 0, "width": VIEWPORT["width"], "height": VIEWPORT["height"] - 70}
"""The 3D view above viser's playback bar (whose clock and slider move on their own)."""
MOVED_FRACTION = 0.002
"""Two frames of the motion differ on more than this fraction of the view."""
STILL_FRACTION = 0.0005


@pytest.fixture(scope="module")
def replay_folder(tmp_path_factory) -> Path:
    robot = load_robot("servo_biped")
    scene = headless_scene(
        robot, "com_shift", {}, preset_params("uniform", robot), default_servos(robot), "uniform"
    )
    return export_replay(robot, scene, tmp_path_factory.mktemp("share") / "replay").folder.path


@pytest.fixture(scope="module")
def static_url(replay_folder: Path) -> Iterator[str]:
    """A static web server on the replay folder: the studio is not involved."""
    with static_server(replay_folder) as url:
        yield url


def view(page) -> np.ndarray:
    png = page.screenshot(
        clip=SCENE_CLIP,
        mask=[page.locator(".mantine-Notification-root")],
        mask_color="#000000",
        animations="disabled",
    )
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.int16)


def wait_until_playing(page) -> None:
    """Wait for a replay page's first render, then for its view to change on its own: the
    replay plays (the robot and its ghosts move)."""
    first = wait_for(
        "the replay's first render",
        lambda: (lambda image: image if not_blank(image) else None)(view(page)),
        RENDER_TIMEOUT_S,
    )
    wait_for(
        "the replay to play",
        lambda: changed(view(page), first).mean() > MOVED_FRACTION,
        RENDER_TIMEOUT_S,
    )


def test_the_replay_plays_from_a_static_server(chromium, static_url: str):
    context = studio_context(chromium, viewport=VIEWPORT)
    page = context.new_page()
    page.set_default_timeout(UI_TIMEOUT_S * 1000)  # busy machines are slow
    requested: list[str] = []
    page.on("request", lambda request: requested.append(request.url))
    try:
        page.goto(static_url)
        wait_for("index.html to open the viewer", lambda: "playbackPath=" in page.url, UI_TIMEOUT_S)
        wait_until_playing(page)
        # Paused (space bar, viser's playback shortcut): the view stops changing, so the
        # change above came from playback, not from the page settling.
        page.keyboard.press("Space")
        previous = [view(page)]

        def still() -> bool:
            image = view(page)
            calm = changed(image, previous[0]).mean() < STILL_FRACTION
            previous[0] = image
            return calm

        wait_for("the paused replay to hold still", still, RENDER_TIMEOUT_S)
        for _ in range(3):
            assert changed(view(page), previous[0]).mean() < STILL_FRACTION
        # Everything came from the static server: the page needs nothing else.
        origin = static_url.rstrip("/")
        outside = [u for u in requested if not re.match(rf"({re.escape(origin)}/|data:|blob:)", u)]
        assert outside == []
        assert any(u.endswith("/recording.viser") for u in requested)
    finally:
        context.close()


def test_screenshot_and_follow_presenter(chromium, tmp_path):
    """A studio of its own (the replay test above runs with none): *Screenshot* in the Share
    folder arrives in the browser as a PNG download of what the tab shows (compared with
    Chromium's own picture of the page, coarsely), and nothing is written on the server; then a
    second tab ticks *Follow presenter* and, when the first tab's camera is dragged round,
    shows the same view."""
    from app.config import StudioConfig
    from app.studio import Studio
    from tests.browser.conftest import _free_port
    from tests.browser.page_helpers import (
        click_button,
        dismiss_software_webgl_warning,
        folder_title,
        open_share_page,
        shot,
        wait_stable,
    )

    studio = Studio(StudioConfig(port=_free_port(), data_dir=tmp_path / "data"))
    context = studio_context(chromium, viewport=VIEWPORT, accept_downloads=True)
    try:
        page = open_share_page(context, studio.web.url, "Screenshot")
        with page.expect_download(timeout=RENDER_TIMEOUT_S * 1000) as download:
            click_button(page, "Screenshot")
        # The page's own picture once it holds still (meshes still arriving when the button
        # was clicked are in the render too).
        seen = wait_stable(page, "the studio's view", not_blank)
        received = download.value
        assert received.suggested_filename.endswith(".png")
        path = tmp_path / "downloaded.png"
        received.save_as(path)
        assert path.read_bytes().startswith(b"\x89PNG\r\n\x1a\n")
        assert received.suggested_filename in page.get_by_text("Screenshot (").first.inner_text()
        assert not (tmp_path / "data" / "screenshots").exists()  # nothing kept on the server
        image = np.asarray(Image.open(path).convert("RGB"), dtype=np.float64)
        assert not_blank(image.astype(np.int16))
        # The same view as the page's: coarse grey levels on a 32×20 grid correlate strongly,
        # over the cells the page's shot does not mask (the panel, notifications: pure black).
        assert image.shape == seen.shape  # the tab's whole view, at its size
        assert _correlation(image, seen.astype(np.float64)) > 0.8

        viewer = context.new_page()
        viewer.set_default_timeout(120_000)
        viewer.goto(studio.web.url)
        dismiss_software_webgl_warning(viewer)
        wait_stable(viewer, "the viewer's first render", not_blank)
        folder_title(viewer, "Demo").click()
        viewer.get_by_label("Follow presenter").check()
        wait_for(
            "the follower to register", lambda: len(studio.presenting.demo.followers) == 1, 30.0
        )
        before = wait_stable(page, "the presenter's view", not_blank)
        page.mouse.move(300, 400)
        page.mouse.down()
        page.mouse.move(500, 380, steps=8)
        page.mouse.up()
        moved = wait_stable(page, "the presenter's turned view", not_blank)
        assert changed(moved, before).mean() > 0.01

        def same_view() -> bool:
            return _correlation(shot(viewer).astype(np.float64), moved.astype(np.float64)) > 0.97

        wait_for("the follower to show the presenter's view", same_view, RENDER_TIMEOUT_S)
    finally:
        context.close()
        studio.stop()


def _correlation(a: np.ndarray, b: np.ndarray) -> float:
    """Correlation of two views' coarse grey levels, over the cells neither view masks."""
    masked = _grey_grid((a[..., :3] == 0).all(axis=2)[..., None] * 1.0) + _grey_grid(
        (b[..., :3] == 0).all(axis=2)[..., None] * 1.0
    )
    keep = masked == 0
    return float(np.corrcoef(_grey_grid(a)[keep], _grey_grid(b)[keep])[0, 1])


def _grey_grid(image: np.ndarray, shape: tuple[int, int] = (20, 32)) -> np.ndarray:
    grey = image[..., :3].mean(axis=2)
    rows = np.array_split(np.arange(grey.shape[0]), shape[0])
    cols = np.array_split(np.arange(grey.shape[1]), shape[1])
    return np.array([[grey[np.ix_(r, c)].mean() for c in cols] for r in rows])


def test_the_replay_legend_is_in_the_page_with_colours(chromium, static_url: str):
    """The title card and ghost legend are drawn by the page inside the viewport (they used
    to be a 3D label that ran off the top), each ghost with a swatch of its own colour; the
    swatches are seen in the page's own screenshot, not only in its markup."""
    from app.core.replay.legend import ELEMENT_ID
    from app.core.replay.scene import PREDICTED_GHOSTS
    from app.views.ghosts_view import GHOSTS

    context = studio_context(chromium, viewport=VIEWPORT)
    page = context.new_page()
    page.set_default_timeout(UI_TIMEOUT_S * 1000)  # busy machines are slow
    try:
        page.goto(static_url)
        wait_for("index.html to open the viewer", lambda: "playbackPath=" in page.url, UI_TIMEOUT_S)
        card = page.locator(f"#{ELEMENT_ID}")
        card.wait_for(state="visible")
        box = card.bounding_box()
        assert box is not None
        assert box["x"] >= 0 and box["y"] >= 0
        assert box["x"] + box["width"] <= VIEWPORT["width"]
        assert box["y"] + box["height"] <= VIEWPORT["height"]
        assert "servo_biped" in card.inner_text()
        swatches = card.locator(".replay-swatch")
        assert swatches.count() == len(PREDICTED_GHOSTS)
        png = Image.open(io.BytesIO(page.screenshot(animations="disabled"))).convert("RGB")
        pixels = np.asarray(png, dtype=np.int16)
        for i, name in enumerate(PREDICTED_GHOSTS):
            rgb, text = GHOSTS[name]
            row = swatches.nth(i).locator("xpath=..")
            assert text in row.inner_text()
            swatch = swatches.nth(i).bounding_box()
            assert swatch is not None and swatch["width"] >= 8 and swatch["height"] >= 8
            assert swatch["y"] >= 0 and swatch["y"] + swatch["height"] <= VIEWPORT["height"]
            # the swatch's centre pixel, as Chromium drew it
            x = int(swatch["x"] + swatch["width"] / 2)
            y = int(swatch["y"] + swatch["height"] / 2)
            assert np.abs(pixels[y, x] - np.array(rgb)).max() <= 6, (name, pixels[y, x], rgb)
    finally:
        context.close()
