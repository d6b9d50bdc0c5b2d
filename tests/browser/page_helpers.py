"""Driving the studio's page in tests: waiting, screenshots of the 3D view and comparing them,
finding viser's folders, buttons and number inputs by their labels."""

from __future__ import annotations

import contextlib
import io
import math
import re
import socket
import subprocess
import sys
import threading
import time
import urllib.request
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TypeVar

import numpy as np
import pytest
from PIL import Image
from playwright.sync_api import Error as PlaywrightError

# Bounds on hangs, not expectations: on a busy 2-core machine with software WebGL a click
# was seen to take 30 s to land, so these are generous (a wait ends as soon as the page shows).
RENDER_TIMEOUT_S = 240.0
UI_TIMEOUT_S = 120.0
POLL_S = 0.25
# How often an action is tried again on an input the page replaced under it.
DETACHED_RETRIES = 5
# A pixel "differs" when a channel moves by more than this (0-255): well above the noise of
# antialiasing and of SwiftShader, well below a robot part against the grid.
PIXEL_DELTA = 40
# Stable: two successive shots differ on fewer pixels than this fraction.
STABLE_FRACTION = 0.0005
T = TypeVar("T")


def wait_for(what: str, probe: Callable[[], T | None], timeout_s: float) -> T:
    """Poll `probe` until it returns something other than None or False (numpy's False too: a
    probe `a and b` gives `np.False_` while a numpy comparison fails); fail naming `what`
    after the timeout."""
    deadline = time.monotonic() + timeout_s
    while True:
        result = probe()
        if result is not None and not (isinstance(result, (bool, np.bool_)) and not result):
            return result
        if time.monotonic() > deadline:
            pytest.fail(f"timed out after {timeout_s:.0f} s waiting for {what}", pytrace=False)
        time.sleep(POLL_S)


def shot(page) -> np.ndarray:
    """The 3D view as an RGB array; the control panel and notifications are painted black so
    that only the scene can make two shots differ."""
    png = page.screenshot(
        mask=[page.locator("[data-dock-group]"), page.locator(".mantine-Notification-root")],
        mask_color="#000000",
        animations="disabled",
    )
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=np.int16)


def changed(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Boolean mask of the pixels that differ between two shots."""
    return np.abs(a - b).max(axis=2) > PIXEL_DELTA


def not_blank(image: np.ndarray) -> bool:
    """A drawn scene, not a cleared canvas: varied colours and contrast."""
    colours = np.unique(image.reshape(-1, 3)[::7], axis=0)
    return len(colours) > 50 and float(image.std()) > 10.0


def wait_stable(
    page, what: str, accept: Callable[[np.ndarray], bool], timeout_s: float = RENDER_TIMEOUT_S
):
    """The first shot that `accept`s and equals the shot taken just before it."""
    previous: list[np.ndarray] = []

    def probe() -> np.ndarray | None:
        image = shot(page)
        ok = accept(image)
        stable = ok and bool(previous) and changed(image, previous[0]).mean() < STABLE_FRACTION
        previous[:] = [image] if ok else []
        return image if stable else None  # an array: wait_for tests it against None

    return wait_for(what, probe, timeout_s)


HIDE_WEBGL_NOTICE_CSS = "#webgl-software-rendering { display: none !important; }"
HIDE_WEBGL_NOTICE_SCRIPT = (
    "document.addEventListener('DOMContentLoaded', () => {"
    " const style = document.createElement('style');"
    f" style.textContent = {HIDE_WEBGL_NOTICE_CSS!r};"
    " document.head.appendChild(style); });"
)
"""Installed on every page of the browser fixtures (context.add_init_script)."""


NOTIFICATION_RECORDER_SCRIPT = """
document.addEventListener("DOMContentLoaded", () => {
  const notices = [];
  const seen = new Set();
  window.__notices = notices;
  const check = () => {
    for (const root of document.querySelectorAll(".mantine-Notification-root")) {
      const text = root.textContent || "";
      if (!seen.has(text)) { seen.add(text); notices.push({ text, t: performance.now() }); }
    }
  };
  new MutationObserver(check).observe(document.body, {
    subtree: true, childList: true, characterData: true,
  });
});
"""
"""Installed on every page of the browser fixtures: records each notification's text (every
version of it) when it appears, so one that closes itself before a busy machine's poll sees it
is still read (notifications_seen)."""


def studio_context(chromium, **options):
    """A new browser context whose pages hide the software-WebGL notice and record their
    notifications (as the browser_page fixture's do). Its waits (a screenshot waits for the
    next frame) are bounded by RENDER_TIMEOUT_S, not Playwright's 30 s: a software-WebGL frame
    of a replay's detailed lighting was seen to take longer on a busy machine."""
    context = chromium.new_context(**options)
    context.set_default_timeout(RENDER_TIMEOUT_S * 1000)
    context.add_init_script(HIDE_WEBGL_NOTICE_SCRIPT)
    context.add_init_script(NOTIFICATION_RECORDER_SCRIPT)
    return context


def notifications_seen(page) -> list[str]:
    """Every notification text the page has shown since it loaded, in order of appearance."""
    return [e["text"] for e in page.evaluate("() => window.__notices || []")]


def wait_notified(page, title: str, text: str, timeout_s: float) -> None:
    """Wait until the page has shown a notification titled `title` containing `text`,
    including one that already closed itself."""
    wait_for(
        f"the notification {title!r} ({text})",
        lambda: any(title in n and text in n for n in notifications_seen(page)) or None,
        timeout_s,
    )


def dismiss_software_webgl_warning(page) -> None:
    """viser warns about SwiftShader with a sticky notification; hide it for a clean picture.
    Cosmetic: a style sheet, no click and no wait, so it can never fail or slow a test (on a
    busy machine, clicking its close button timed out and failed tests)."""
    with contextlib.suppress(Exception):
        page.add_style_tag(content=HIDE_WEBGL_NOTICE_CSS)


def open_share_page(context, url: str, inside: str):
    """A new page of `context` on the studio at `url`, past the software-WebGL warning, its
    Share folder open at the button `inside`, once its first render holds still."""
    page = context.new_page()
    page.set_default_timeout(120_000)
    page.goto(url)
    dismiss_software_webgl_warning(page)
    expand_folder(page, "Share", inside)
    wait_stable(page, "the studio's first render", not_blank)
    return page


def collect(signal) -> tuple[list, threading.Event]:
    """(values, done): what `signal` emits is appended to values; done is set at the first."""
    values: list = []
    done = threading.Event()
    signal.connect(lambda value: (values.append(value), done.set()))
    return values, done


def gui_row_input(page, label: str, css: str):
    """The input `css` in the GUI row whose label reads exactly `label` (viser puts the label
    in a <label> and the controls in the same flex row)."""
    text = page.locator("label", has_text=re.compile(rf"^{re.escape(label)}$"))
    row = text.locator("xpath=ancestor::div[contains(@class, 'mantine-Flex-root')][1]")
    return row.locator(css)


def box_of(mask: np.ndarray, margin: int = 20) -> tuple[slice, slice]:
    rows, cols = np.nonzero(mask)
    height, width = mask.shape
    return (
        slice(max(0, rows.min() - margin), min(height, rows.max() + margin + 1)),
        slice(max(0, cols.min() - margin), min(width, cols.max() + margin + 1)),
    )


def folder_title(page, label: str):
    """The clickable title bar of the GUI folder `label` (viser draws it as a Paper holding
    only the label text and a chevron icon, inside the folder's own Paper)."""
    return page.locator(".mantine-Paper-root", has_text=re.compile(rf"^{re.escape(label)}$"))


def folder(page, label: str):
    """The whole GUI folder `label`: the title bar's parent."""
    return folder_title(page, label).locator("xpath=..")


def expand_folder(page, label: str, inside: str) -> None:
    """Click a collapsed folder's title, as a user would, until the button `inside` shows."""
    button = page.get_by_role("button", name=inside, exact=True)
    if not button.is_visible():
        folder_title(page, label).click()
    button.wait_for(state="visible", timeout=UI_TIMEOUT_S * 1000)


def click_button(page, name: str) -> None:
    button = page.get_by_role("button", name=name, exact=True)
    button.scroll_into_view_if_needed()
    button.click()


def pause_playback(page) -> None:
    """Click *Pause* if a motion is playing (a loaded sweep point or a simulation plays on a
    loop), as a user does before editing: while it plays, a software renderer redraws the scene
    between clicks and each click waits 3-5 s for the page."""
    pause = page.get_by_role("button", name="Pause", exact=True)
    if pause.is_visible():
        pause.click()
        page.get_by_role("button", name="Play", exact=True).wait_for(state="visible")


def type_number(page, label: str, value: float) -> None:
    """Type `value` into the number input `label` and press Enter. The panel may redraw its
    inputs while the page settles (a motion's parameters after a pick): an input replaced
    between finding it and typing is found again."""
    for attempt in range(DETACHED_RETRIES):
        box = gui_row_input(page, label, "input.mantine-NumberInput-input")
        try:
            box.scroll_into_view_if_needed()
            box.fill(f"{value:g}")
            box.press("Enter")
            return
        except PlaywrightError as error:
            if "not attached" not in str(error) or attempt == DETACHED_RETRIES - 1:
                raise


def select_option(page, label: str, option: str) -> None:
    """Open the dropdown `label` (a Mantine Select) and click `option` in its list."""
    box = gui_row_input(page, label, "input.mantine-Select-input")
    box.scroll_into_view_if_needed()
    box.click()
    page.get_by_role("option", name=option, exact=True).click()
    wait_for(
        f"the page's {label} to show {option}",
        lambda: box.input_value() == option,
        UI_TIMEOUT_S,
    )


def generate_motion(page, studio, motion: str, timeout_s: float = UI_TIMEOUT_S):
    """Pick `motion` in the Motions folder and press *Generate*; the studio's trajectory."""
    expand_folder(page, "Motions", "Generate")
    select_option(page, "Motion", motion)
    click_button(page, "Generate")
    return wait_for(
        f"the generated {motion}",
        lambda: (t := studio.state.trajectory) is not None and t.name == motion and t,
        timeout_s,
    )


COMPUTE_TORQUES = "Compute torque feed-forward"
SIMULATE = "Simulate without / with compensation"
SIMULATE_TIMEOUT_S = 180.0
"""Bounds *Simulate*: spawn the simulation worker (if the torques did not already), run
MuJoCo twice."""


def compute_torques_in_page(page, studio, what: str = "the quick estimate"):
    """Open the Compensation folder and press *Compute torque feed-forward*, as a user does;
    the studio's quick estimate once the torques (computed in a worker) give one."""
    expand_folder(page, "Compensation", COMPUTE_TORQUES)
    click_button(page, COMPUTE_TORQUES)
    return wait_for(what, lambda: studio.state.work.prediction, RENDER_TIMEOUT_S)


def simulate_in_page(page, studio):
    """Press *Simulate without / with compensation*; the run of the studio's next simulation
    record (not the one before the click)."""
    before = studio.state.work.simulation
    click_button(page, SIMULATE)
    record = wait_for(
        "the simulation",
        lambda: (s := studio.state.work.simulation) is not None and s is not before and s,
        RENDER_TIMEOUT_S * 2,
    )
    return record.run


def simulate_until_shown(page):
    """Press *Simulate without / with compensation* and wait until the Compensation folder
    shows the verdict's first line ("Simulated (MuJoCo) in", case-sensitive: the ghost legend
    says "simulated" too); the folder."""
    click_button(page, SIMULATE)
    compensation = folder(page, "Compensation")
    compensation.get_by_text(re.compile(r"Simulated \(MuJoCo\) in")).first.wait_for(
        state="visible", timeout=SIMULATE_TIMEOUT_S * 1000
    )
    return compensation


def folder_shows(page, label: str, pattern: str) -> str | None:
    """The text of the GUI folder `label` when `pattern` (a regex) is in it, else None."""
    text = folder(page, label).inner_text()
    return text if re.search(pattern, text) else None


def page_time_s(page) -> float:
    """The value the page shows in the number box beside the "Time [s]" slider."""
    text = gui_row_input(page, "Time [s]", "input.mantine-NumberInput-input").input_value()
    try:
        return float(text)
    except ValueError:
        return math.nan


def scene_canvas_box(page) -> dict:
    """The 3D view's canvas on the page (the largest canvas: plots have small ones), as
    Playwright's bounding box {x, y, width, height} [px]."""
    boxes = [c.bounding_box() for c in page.locator("canvas").all()]
    box = max((b for b in boxes if b is not None), key=lambda b: b["width"] * b["height"])
    return box


def screen_point(camera, point_m: np.ndarray, canvas: dict) -> tuple[float, float]:
    """The page pixel (x, y) where world `point_m` is drawn, seen by a tab's `camera` (viser's
    CameraHandle: position, look_at, up_direction, vertical fov) on `canvas`: the pinhole
    model three.js's PerspectiveCamera draws with. To click a scene node as a user would."""
    eye, look_at = np.asarray(camera.position, float), np.asarray(camera.look_at, float)
    forward = (look_at - eye) / np.linalg.norm(look_at - eye)
    right = np.cross(forward, np.asarray(camera.up_direction, float))
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    d = np.asarray(point_m, float) - eye
    depth = float(d @ forward)
    assert depth > 0, "the point is behind the camera"
    focal = 0.5 * canvas["height"] / math.tan(0.5 * float(camera.fov))
    x = canvas["x"] + 0.5 * canvas["width"] + focal * float(d @ right) / depth
    y = canvas["y"] + 0.5 * canvas["height"] - focal * float(d @ up) / depth
    return x, y


# Records, on the page's clock (performance.now(), ms), when each text first appears in the
# page: a notification that closes itself, or a stage that passes faster than a poll, is
# still seen.
TEXT_RECORDER_JS = """
([name, markers]) => {
  const rec = [];
  window["__texts_" + name] = rec;
  const present = {};
  const check = () => {
    const text = document.body.textContent || "";
    for (const marker of markers) {
      const now = text.includes(marker);
      if (now && !present[marker]) rec.push({ marker, t: performance.now() });
      present[marker] = now;
    }
  };
  check();
  new MutationObserver(check).observe(document.body, {
    subtree: true, childList: true, characterData: true,
  });
}
"""


def record_texts(page, name: str, markers: tuple[str, ...]) -> None:
    """Start recording when each of `markers` first appears in the page (see texts_seen)."""
    page.evaluate(TEXT_RECORDER_JS, [name, list(markers)])


def texts_seen(page, name: str) -> list[tuple[str, float]]:
    """(marker, page time in ms) for each appearance recorded by record_texts, in order."""
    events = page.evaluate("(name) => window['__texts_' + name] || []", name)
    return [(e["marker"], float(e["t"])) for e in events]


def open_studio(page, url: str):
    """`page` on the studio at `url`, connected (its Playback folder drawn), the software-WebGL
    notice hidden: how a module's tests start (once per module: page loads are slow)."""
    page.goto(url)
    folder_title(page, "Playback").wait_for(state="visible", timeout=RENDER_TIMEOUT_S * 1000)
    dismiss_software_webgl_warning(page)
    return page


FRAME_INTERVAL_JS = """(seconds) => new Promise((resolve) => {
  const start = performance.now(); let frames = 0;
  function frame(now) {
    frames++;
    if (now - start < seconds * 1000) requestAnimationFrame(frame);
    else resolve((now - start) / frames);
  }
  requestAnimationFrame(frame);
})"""


def frame_interval_ms(page, seconds: float = 3.0) -> float:
    """The page's mean time between animation frames over `seconds` [ms] (for the log: what a
    software renderer on a busy machine gives, never asserted)."""
    return float(page.evaluate(FRAME_INTERVAL_JS, seconds))


@contextlib.contextmanager
def static_server(folder: Path) -> Iterator[str]:
    """`python -m http.server` serving `folder` (a replay plays from any static web server:
    the studio is not involved); yields its URL."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    server = subprocess.Popen(
        [sys.executable, "-m", "http.server", str(port), "--bind", "127.0.0.1"],
        cwd=folder,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    url = f"http://127.0.0.1:{port}/"

    def answers() -> bool:
        try:
            with urllib.request.urlopen(url):
                return True
        except OSError:
            return False

    try:
        wait_for("the static server", answers, UI_TIMEOUT_S)
        yield url
    finally:
        server.terminate()
        server.wait()


STATIC = Path(__file__).resolve().parents[2] / "static"
"""The pictures of the README and docs/."""


def publish(page, name: str) -> None:
    """With BIPED_STUDIO_SCREENSHOT=1, write the page as the docs' picture static/`name`:
    the pictures are what the tests' pages show, made anew by one run."""
    import os

    if os.environ.get("BIPED_STUDIO_SCREENSHOT") == "1":
        STATIC.mkdir(parents=True, exist_ok=True)
        page.screenshot(path=str(STATIC / name))


def chart_pixels(page, label: str, colours: tuple[tuple[int, int, int], ...]) -> list[int]:
    """How many pixels of each of `colours` (RGB) the first chart (uPlot canvas) of the GUI
    folder `label` shows: what the chart drew, not what the server sent it. A chart the panel
    replaced while it was read (a new plot rebuilt in place) counts as nothing drawn yet, so
    that a `wait_for` on it reads the new one at its next poll."""
    canvas = folder(page, label).locator(".uplot canvas").first
    try:
        canvas.scroll_into_view_if_needed()
        png = canvas.screenshot()
    except PlaywrightError as error:
        if "not attached" not in str(error):
            raise
        return [0] * len(colours)
    image = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=int)
    return [int((np.abs(image - np.array(rgb)).max(axis=2) < 40).sum()) for rgb in colours]
