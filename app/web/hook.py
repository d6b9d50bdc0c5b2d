"""A request hook on the web server viser starts (its private reaches: app.web.viser_internals).

viser 1.1.1 offers no hook on its HTTP/websocket server. `viser.infra.WebsockServer`
starts `websockets.asyncio.server.serve(..., process_request=viser_http_server)` on a
background thread inside `ViserServer.__init__`, and serves the page and the
websocket on the same port. To check every request *before* viser answers it, the
websockets `serve` that viser calls is swapped, only while `hooked_viser_server`
constructs the server, for one that wraps viser's `process_request`:

    process_request'(connection, request) = refusal            if the policy refuses
                                          = viser's answer + security headers otherwise

The swap is scoped (the name `websockets` as viser's server code sees it, restored at once,
under a lock) and checked: viser must be the pinned version (`check_viser_version`), and if
viser's internals change so that the hooked `serve` is not called, `hooked_viser_server`
stops the server and raises `ViserHookError` rather than serve the studio unguarded.
`tests/test_web_guard.py` exercises this on every run.
"""

from __future__ import annotations

import http
import threading
from collections.abc import Callable
from types import ModuleType
from typing import Any

import viser
from websockets.asyncio.server import ServerConnection
from websockets.datastructures import Headers
from websockets.http11 import Request, Response

from app.web.access import SECURITY_HEADERS, TOKEN_PAGE, AccessPolicy
from app.web.viser_internals import (
    ViserHookError,
    check_viser_version,
    viser_websockets,
    websockets_seen_by_viser,
)

ProcessRequest = Callable[[ServerConnection, Request], "Response | None"]

_SWAP_LOCK = threading.Lock()


class _Overlay:
    """A module seen through `overrides`: other attributes come from the real module."""

    def __init__(self, real: ModuleType | _Overlay, **overrides: Any) -> None:
        self._real = real
        self._overrides = overrides

    def __getattr__(self, name: str) -> Any:
        if name in self._overrides:
            return self._overrides[name]
        return getattr(self._real, name)


def hooked_viser_server(
    make: Callable[[], viser.ViserServer], wrap: Callable[[ProcessRequest | None], ProcessRequest]
) -> viser.ViserServer:
    """`make()` with every request to its server going through `wrap(viser's process_request)`."""
    check_viser_version()
    real = viser_websockets()
    calls: list[int] = []

    def serve(*args: Any, **kwargs: Any) -> Any:
        kwargs["process_request"] = wrap(kwargs.get("process_request"))
        calls.append(1)
        return real.asyncio.server.serve(*args, **kwargs)

    overlay = _Overlay(
        real, asyncio=_Overlay(real.asyncio, server=_Overlay(real.asyncio.server, serve=serve))
    )
    with _SWAP_LOCK, websockets_seen_by_viser(overlay):
        server = make()
    if not calls:
        server.stop()
        raise ViserHookError(
            f"viser {viser.__version__} did not start its server through "
            "websockets.asyncio.server.serve: the studio's request guard could not be "
            "installed, so it refuses to serve. Pin viser==1.1.1 or update app/web/hook.py."
        )
    return server


def guard_requests(policy: AccessPolicy) -> Callable[[ProcessRequest | None], ProcessRequest]:
    """The `wrap` for `hooked_viser_server` that applies `policy` to every request."""

    def wrap(inner: ProcessRequest | None) -> ProcessRequest:
        def process_request(connection: ServerConnection, request: Request) -> Response | None:
            websocket = request.headers.get("Upgrade", "").lower() == "websocket"
            port = int(connection.local_address[1])
            verdict = policy.check(request.path, list(request.headers.raw_items()), port, websocket)
            if not verdict.allowed:
                if verdict.status == 401 and not websocket:
                    return _page(http.HTTPStatus.UNAUTHORIZED, TOKEN_PAGE, "text/html")
                return _page(http.HTTPStatus(verdict.status), verdict.reason + "\n", "text/plain")
            response = inner(connection, request) if inner is not None else None
            if response is not None:
                _add_security_headers(response.headers)
                if verdict.set_cookie:
                    response.headers["Set-Cookie"] = policy.cookie_header(port)
            return response

        return process_request

    return wrap


def _page(status: http.HTTPStatus, text: str, content_type: str) -> Response:
    body = text.encode()
    headers = Headers(
        [
            ("Content-Type", f"{content_type}; charset=utf-8"),
            ("Content-Length", str(len(body))),
            ("Cache-Control", "no-store"),
            ("Connection", "close"),
        ]
    )
    _add_security_headers(headers)
    return Response(status.value, status.phrase, headers, body)


def _add_security_headers(headers: Headers) -> None:
    for name, value in SECURITY_HEADERS:
        headers[name] = value
