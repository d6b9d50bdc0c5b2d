"""Fixtures for the browser tests: a real studio on a free port and a headless Chromium page.

Chromium is the Debian package (/usr/bin/chromium): Playwright cannot download its own
browsers here. WebGL runs in software (SwiftShader), so a page load and first render take
~10-20 s; the fixtures are module-scoped so that a test module loads the page once.

Environment:
  BIPED_STUDIO_SKIP_BROWSER=1     skip these tests when Chromium is missing (else they fail)
  BIPED_STUDIO_CHROMIUM=...       another Chromium binary (default /usr/bin/chromium)
  BIPED_STUDIO_BROWSER_ROBOT=...  robot the studio opens (built-in name or URDF path)
  BIPED_STUDIO_SCREENSHOT=1       also write the docs' pictures (static/*.png) from the pages
                                  the tests show (page_helpers.publish)
"""

from __future__ import annotations

import os
import socket
from collections.abc import Iterator
from pathlib import Path
from typing import NoReturn

import pytest

from app.config import StudioConfig
from app.studio import Studio
from tests.browser.page_helpers import open_studio, studio_context

HERE = Path(__file__).resolve().parent
CHROMIUM = Path(os.environ.get("BIPED_STUDIO_CHROMIUM", "/usr/bin/chromium"))
CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
    "--use-gl=angle",
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
]
VIEWPORT = {"width": 1280, "height": 800}
DEFAULT_ROBOT = "servo_biped"


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Every test in this folder drives a browser: mark it so `-m "not browser"` skips it."""
    for item in items:
        if item.path.is_relative_to(HERE):
            item.add_marker(pytest.mark.browser)


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def _unavailable(reason: str) -> NoReturn:
    """Fail loudly (a silently skipped browser test looks like a passing one) unless asked."""
    if os.environ.get("BIPED_STUDIO_SKIP_BROWSER") == "1":
        pytest.skip(f"{reason} (BIPED_STUDIO_SKIP_BROWSER=1)")
    pytest.fail(
        f"{reason}; set BIPED_STUDIO_SKIP_BROWSER=1 to skip the browser tests", pytrace=False
    )


@pytest.fixture(scope="module")
def studio_robot() -> str:
    """The robot the studio opens; override this fixture or set BIPED_STUDIO_BROWSER_ROBOT."""
    return os.environ.get("BIPED_STUDIO_BROWSER_ROBOT", DEFAULT_ROBOT)


@pytest.fixture(scope="module")
def studio(studio_robot: str, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Studio]:
    """A real studio (real viser server) on a free local port, stopped after the module."""
    config = StudioConfig(
        robot=studio_robot,
        host="127.0.0.1",
        port=_free_port(),
        data_dir=tmp_path_factory.mktemp("studio-data"),
    )
    running = Studio(config)
    try:
        yield running
    finally:
        running.stop()


@pytest.fixture(scope="module")
def studio_url(studio: Studio) -> str:
    """The studio's link with its access token (without it the page is only a notice)."""
    return studio.web.url


@pytest.fixture(scope="module")
def page(browser_page, studio_url: str):
    """The studio page, loaded once for the module and connected (`open_studio`: its Playback
    folder drawn, the software-WebGL notice hidden); the module's tests continue from one
    another on it. A module that needs more overrides it, taking this one by the same name."""
    return open_studio(browser_page, studio_url)


@pytest.fixture(scope="session")
def chromium() -> Iterator[object]:
    """A headless Debian Chromium driven by Playwright, launched once for the run: each module
    still gets a context of its own (`browser_page`: its own cookies, storage and pages)."""
    if not CHROMIUM.exists():
        _unavailable(f"{CHROMIUM} not found: run `apt-get install chromium chromium-driver`")
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        _unavailable("playwright is not installed: run `pip install -e .[test]`")
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(
            executable_path=str(CHROMIUM), headless=True, args=CHROMIUM_ARGS
        )
        try:
            yield browser
        finally:
            browser.close()


@pytest.fixture(scope="module")
def browser_page(chromium) -> Iterator[object]:
    """A fresh 1280x800 page, shared by the tests of a module (page loads are slow)."""
    context = studio_context(chromium, viewport=VIEWPORT)
    page = context.new_page()
    page.set_default_timeout(120_000)  # bounds a hang; busy machines are slow
    try:
        yield page
    finally:
        context.close()
