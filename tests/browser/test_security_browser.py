"""The web door in a real Chromium (issue 16): with the token viser's page works, without it
only the notice loads, a page of another origin cannot open the studio's websocket even
though the browser holds the studio's cookie, the page cannot be framed, and an upload over
the limit is refused while it streams.

A plain viser server built through `app.web.guard` stands in for the studio (its page is
viser's own, and it loads in seconds where the studio's scene takes much longer).
"""

from __future__ import annotations

import contextlib
import http.server
import threading
from collections.abc import Iterator

import pytest

from app.web.access import new_token
from app.web.guard import GuardedServer, guarded_server
from tests.browser.page_helpers import UI_TIMEOUT_S, studio_context, wait_for

LIMIT = 1_000_000
BUTTON = "Guarded button"

HOSTILE_PAGE = """<!doctype html><html><body>
<iframe id="framed" src="{studio}"></iframe>
<script>
window.result = "pending";
const ws = new WebSocket("ws://127.0.0.1:{port}/", ["{subprotocol}"]);
ws.onopen = () => {{ window.result = "open"; }};
ws.onerror = () => {{ window.result = "error"; }};
</script></body></html>
"""


@pytest.fixture(scope="module")
def web() -> Iterator[GuardedServer]:
    guarded = guarded_server("127.0.0.1", 0, new_token(), max_upload_bytes=LIMIT)
    guarded.server.gui.add_button(BUTTON)
    guarded.server.gui.add_upload_button("Upload a robot")
    try:
        yield guarded
    finally:
        guarded.server.stop()


@pytest.fixture(scope="module")
def context(chromium) -> Iterator[object]:
    """One browser profile for the module: the cookie the tokened page sets stays in it."""
    ctx = studio_context(chromium, viewport={"width": 1280, "height": 800})
    try:
        yield ctx
    finally:
        ctx.close()


@pytest.fixture(scope="module")
def hostile_site(web: GuardedServer) -> Iterator[str]:
    """Another origin on this machine (127.0.0.1, another port) serving HOSTILE_PAGE."""
    import viser

    page = HOSTILE_PAGE.format(
        port=web.server.get_port(), subprotocol=f"viser-v{viser.__version__}", studio=web.url
    ).encode()

    class Handler(http.server.BaseHTTPRequestHandler):
        def do_GET(self) -> None:
            self.send_response(200)
            self.send_header("Content-Type", "text/html")
            self.send_header("Content-Length", str(len(page)))
            self.end_headers()
            self.wfile.write(page)

        def log_message(self, *args: object) -> None:
            pass

    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}/"
    finally:
        server.shutdown()
        server.server_close()


def test_without_the_token_only_the_notice_loads(context, web: GuardedServer) -> None:
    page = context.new_page()
    try:
        response = page.goto(f"http://127.0.0.1:{web.server.get_port()}/")
        assert response is not None and response.status == 401
        assert "needs its access link" in page.content()
        assert page.get_by_text(BUTTON).count() == 0
        assert web.server.get_clients() == {}
        assert context.cookies() == []
    finally:
        page.close()


@contextlib.contextmanager
def tokened_page(context, web: GuardedServer) -> Iterator:
    """A tab on the server's tokened link, once viser's client shows the page; closed after."""
    page = context.new_page()
    page.set_default_timeout(UI_TIMEOUT_S * 1000)
    try:
        page.goto(web.url)
        page.get_by_text(BUTTON).wait_for(state="visible")  # viser's client connected
        yield page
    finally:
        page.close()


def test_with_the_token_the_page_works(context, web: GuardedServer) -> None:
    with tokened_page(context, web):
        wait_for("the tab to register", lambda: web.server.get_clients() or None, UI_TIMEOUT_S)
        (cookie,) = context.cookies()
        assert cookie["httpOnly"] and cookie["sameSite"] == "Strict"
        assert cookie["value"] == web.policy.token


def test_a_page_of_another_origin_cannot_connect_or_frame(
    context, web: GuardedServer, hostile_site: str
) -> None:
    """Run after the tokened load: the browser holds the cookie, and 127.0.0.1:another port
    is the same *site* (cookies ignore ports), so only the Origin check stops the page."""
    assert context.cookies(), "run with the previous test: the cookie must be present"
    page = context.new_page()
    try:
        clients_before = set(web.server.get_clients())
        page.goto(hostile_site)
        settled = "window.result === 'pending' ? null : window.result"
        result = wait_for(
            "the hostile websocket to settle", lambda: page.evaluate(settled), UI_TIMEOUT_S
        )
        assert result == "error"
        assert set(web.server.get_clients()) == clients_before
        # X-Frame-Options: DENY: Chromium replaces the framed studio by its error page.
        framed = wait_for(
            "the framed studio to settle",
            lambda: next(
                (f.url for f in page.frames[1:] if f.url not in ("", "about:blank")), None
            ),
            UI_TIMEOUT_S,
        )
        assert framed.startswith("chrome-error://")
    finally:
        page.close()


def test_an_oversize_upload_is_refused_while_it_streams(context, web: GuardedServer) -> None:
    with tokened_page(context, web) as page:
        dropped = len(web.uploads.dropped)
        page.locator("input[type=file]").set_input_files(
            files=[{"name": "big.zip", "mimeType": "application/zip", "buffer": b"\0" * 3 * LIMIT}]
        )
        page.get_by_text("Upload refused").wait_for(state="visible")
        assert [d.filename for d in web.uploads.dropped[dropped:]] == ["big.zip"]
        assert web.uploads.held_bytes() == 0
