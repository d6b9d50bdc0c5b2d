"""The studio's web door (issue 16): Host, Origin and token checks on a real viser server,
spoken to by hand over raw HTTP and websockets as a hostile client would, and uploads
bounded while they stream.

The rules come from the specifications, not from our code: RFC 6455 §10.2 (a server
must check Origin to refuse pages of other origins), RFC 6265 (cookies ignore ports,
so another port of 127.0.0.1 is "same site" and only the Origin check stops it), and
the DNS-rebinding defence (a Host that is not ours is refused).
"""

from __future__ import annotations

import asyncio
import http.client
import subprocess
import sys
import threading
import uuid
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import IO, TypeVar

import pytest
import viser
import websockets
from viser import _messages as viser_messages
from websockets.asyncio.client import ClientConnection

from app.web.access import (
    TOKEN_PAGE,
    AccessPolicy,
    InsecureServeError,
    check_bind,
    cookie_name,
    new_token,
    studio_url,
)
from app.web.guard import GuardedServer, guarded_server
from app.web.hook import ViserHookError, guard_requests, hooked_viser_server
from tests.viser_wire import CAMERA as CAMERA_MESSAGE
from tests.viser_wire import SUBPROTOCOL, encode

VISER_PAGE = Path(viser.__file__).parent / "client" / "build" / "index.html"
LIMIT = 1_000_000
T = TypeVar("T")


# --- a raw client ---------------------------------------------------------------------


def http_get(
    port: int, path: str = "/", headers: dict[str, str] | None = None
) -> tuple[int, dict[str, str], bytes]:
    """(status, headers, body) of a GET to 127.0.0.1:`port`, sending `headers` verbatim."""
    headers = headers or {}
    connection = http.client.HTTPConnection("127.0.0.1", port, timeout=60)
    try:
        connection.putrequest("GET", path, skip_host="Host" in headers)
        for name, value in headers.items():
            connection.putheader(name, value)
        connection.endheaders()
        response = connection.getresponse()
        return response.status, dict(response.getheaders()), response.read()
    finally:
        connection.close()


def handshake(port: int, headers: dict[str, str], query: str = "") -> int:
    """HTTP status of a websocket handshake: 101 when accepted."""

    async def attempt() -> int:
        try:
            async with websockets.connect(
                f"ws://127.0.0.1:{port}/{query}",
                additional_headers=headers,
                subprotocols=[websockets.Subprotocol(SUBPROTOCOL)],
                open_timeout=60,
            ):
                return 101
        except websockets.InvalidStatus as refused:
            return int(refused.response.status_code)

    return asyncio.run(attempt())


CAMERA = encode(CAMERA_MESSAGE)


def start_frame(button: str, size_bytes: int, part_count: int, transfer: str) -> bytes:
    return encode(
        viser_messages.FileTransferStartUpload(
            source_component_uuid=button,
            transfer_uuid=transfer,
            filename="robot.zip",
            mime_type="application/zip",
            part_count=part_count,
            size_bytes=size_bytes,
        )
    )


def part_frame(button: str, transfer: str, index: int, content: bytes) -> bytes:
    return encode(viser_messages.FileTransferPart(button, transfer, index, content))


def honest_upload(button: str, content: bytes, part_bytes: int = 512 * 1024) -> list[bytes]:
    """The frames of one upload of `content`, cut the way viser's client cuts it."""
    parts = [content[i : i + part_bytes] for i in range(0, len(content), part_bytes)]
    transfer = uuid.uuid4().hex
    start = start_frame(button, len(content), len(parts), transfer)
    return [start] + [part_frame(button, transfer, i, p) for i, p in enumerate(parts)]


def stream(port: int, cookie: str, frames: list[bytes], then: Callable[[], T]) -> T:
    """Send `frames` in order on one authorised websocket, then return `then()`, run while
    the connection is still open (viser frees a tab's unfinished uploads when it leaves)."""

    async def run() -> T:
        async with websockets.connect(
            f"ws://127.0.0.1:{port}/",
            additional_headers={"Cookie": cookie, "Origin": f"http://127.0.0.1:{port}"},
            subprotocols=[websockets.Subprotocol(SUBPROTOCOL)],
            max_size=None,
            open_timeout=60,
        ) as ws:
            drain = asyncio.create_task(_drain(ws))
            await ws.send(CAMERA)  # viser counts a tab as connected from its first camera
            for frame in frames:
                await ws.send(frame)
            result = await asyncio.get_running_loop().run_in_executor(None, then)
            drain.cancel()
            return result

    return asyncio.run(run())


async def _drain(ws: ClientConnection) -> None:
    """Read what the server sends (acks, notifications) so its keepalive is answered."""
    async for _ in ws:
        pass


# --- the policy on its own -------------------------------------------------------------

TOKEN = "t" * 43


def verdict(policy: AccessPolicy, headers: list[tuple[str, str]], path: str = "/", ws=True):
    return policy.check(path, headers, 8080, websocket=ws)


@pytest.mark.parametrize(
    "host", ["127.0.0.1:8080", "localhost:8080", "[::1]:8080", "LOCALHOST:8080"]
)
def test_loopback_hosts_on_our_port_are_ours(host: str) -> None:
    policy = AccessPolicy("127.0.0.1", None)
    assert verdict(policy, [("Host", host)]).allowed


@pytest.mark.parametrize(
    "host",
    [
        "127.0.0.1:8081",  # another port
        "127.0.0.1",  # port 80 implied
        "evil.example:8080",  # DNS rebinding: the attacker's name resolving to 127.0.0.1
        "127.0.0.1.nip.io:8080",
        "10.0.0.5:8080",  # an IP that is not the bound host
        "",
    ],
)
def test_other_hosts_are_refused(host: str) -> None:
    assert verdict(AccessPolicy("127.0.0.1", None), [("Host", host)]).status == 403


def test_a_missing_or_repeated_host_is_refused() -> None:
    policy = AccessPolicy("127.0.0.1", None)
    assert verdict(policy, []).status == 403
    twice = [("Host", "127.0.0.1:8080"), ("Host", "evil.example:8080")]
    assert verdict(policy, twice).status == 403


def test_a_wildcard_bind_takes_ip_literals_but_not_foreign_names() -> None:
    policy = AccessPolicy("0.0.0.0", TOKEN)
    query = f"/?token={TOKEN}"
    assert verdict(policy, [("Host", "192.168.1.20:8080")], query).allowed
    assert verdict(policy, [("Host", "[fe80::1]:8080")], query).allowed
    assert verdict(policy, [("Host", "evil.example:8080")], query).status == 403
    named = AccessPolicy("0.0.0.0", TOKEN, extra_hosts=("studio.lan",))
    assert verdict(named, [("Host", "studio.lan:8080")], query).allowed


@pytest.mark.parametrize(
    ("origin", "allowed"),
    [
        ("http://127.0.0.1:8080", True),
        ("http://localhost:8080", True),
        ("http://evil.example.com", False),
        ("http://127.0.0.1:9000", False),  # another local server: same site for cookies
        ("https://127.0.0.1:8080", False),
        ("null", False),  # sandboxed iframes and file:// pages
        ("http://127.0.0.1:8080.evil.example", False),
    ],
)
def test_origin_must_be_the_studio(origin: str, allowed: bool) -> None:
    headers = [("Host", "127.0.0.1:8080"), ("Origin", origin)]
    assert verdict(AccessPolicy("127.0.0.1", None), headers).allowed is allowed


def test_token_from_the_url_or_the_cookie() -> None:
    policy = AccessPolicy("127.0.0.1", TOKEN)
    host = [("Host", "127.0.0.1:8080")]
    assert verdict(policy, host).status == 401
    assert verdict(policy, host, f"/?token={TOKEN[:-1]}x").status == 401
    page = verdict(policy, host, f"/?token={TOKEN}", ws=False)
    assert page.allowed and page.set_cookie
    cookie = [("Cookie", f"other=1; {cookie_name(8080)}={TOKEN}")]
    assert verdict(policy, host + cookie).allowed
    # Cookies ignore ports: another studio's cookie on this host does not open this one.
    assert verdict(policy, [*host, ("Cookie", f"{cookie_name(8081)}={TOKEN}")]).status == 401
    assert policy.cookie_header(8080).endswith("; Path=/; HttpOnly; SameSite=Strict")


def test_tokens_are_random_and_long() -> None:
    tokens = {new_token() for _ in range(50)}
    assert len(tokens) == 50 and min(len(t) for t in tokens) >= 43


def test_no_token_is_refused_beyond_loopback() -> None:
    check_bind("127.0.0.1", None)
    check_bind("0.0.0.0", TOKEN)
    for host in ("0.0.0.0", "::", "192.168.1.20", "studio.lan"):
        with pytest.raises(InsecureServeError, match="--no-token"):
            check_bind(host, None)


def test_studio_url() -> None:
    assert studio_url("0.0.0.0", 8080, TOKEN) == f"http://127.0.0.1:8080/?token={TOKEN}"
    assert studio_url("::1", 8081, None) == "http://[::1]:8081/"


# --- a real server ---------------------------------------------------------------------


@pytest.fixture(scope="module")
def web() -> Iterator[GuardedServer]:
    guarded = guarded_server("127.0.0.1", 0, new_token(), max_upload_bytes=LIMIT)
    try:
        yield guarded
    finally:
        guarded.server.stop()


def own(web: GuardedServer) -> dict[str, str]:
    port = web.server.get_port()
    token = web.policy.token
    return {"Origin": f"http://127.0.0.1:{port}", "Cookie": f"{cookie_name(port)}={token}"}


def test_without_the_token_the_page_is_only_the_notice(web: GuardedServer) -> None:
    port = web.server.get_port()
    status, headers, body = http_get(port, "/")
    assert status == 401 and body == TOKEN_PAGE.encode()
    assert "terminal" in body.decode()
    assert http_get(port, "/index.html?token=wrong")[2] == TOKEN_PAGE.encode()
    assert headers["X-Frame-Options"] == "DENY"


def test_with_the_token_the_page_is_viser_with_a_strict_cookie(web: GuardedServer) -> None:
    port = web.server.get_port()
    status, headers, body = http_get(port, f"/?token={web.policy.token}")
    assert status == 200 and body == VISER_PAGE.read_bytes()
    assert headers["Set-Cookie"] == web.policy.cookie_header(port)
    assert headers["X-Frame-Options"] == "DENY"
    assert headers["Content-Security-Policy"] == "frame-ancestors 'none'"
    cookie = {"Cookie": f"{cookie_name(port)}={web.policy.token}"}
    assert http_get(port, "/", cookie)[2] == VISER_PAGE.read_bytes()


def test_dns_rebinding_is_refused_even_with_the_token(web: GuardedServer) -> None:
    port = web.server.get_port()
    status, _, body = http_get(
        port, f"/?token={web.policy.token}", {"Host": f"attacker.example:{port}"}
    )
    assert status == 403 and b"attacker.example" in body


def test_websocket_handshakes(web: GuardedServer) -> None:
    """Only 101 opens a websocket (RFC 6455 §4.2.2): a refused one never reaches viser."""
    port = web.server.get_port()
    good = own(web)
    refused = {
        "foreign origin": {**good, "Origin": "http://evil.example.com"},
        "another local port": {**good, "Origin": f"http://127.0.0.1:{port + 1}"},
        "null origin": {**good, "Origin": "null"},
        "wrong host": {**good, "Host": f"attacker.example:{port}"},
        "no token": {"Origin": good["Origin"]},
        "wrong token": {**good, "Cookie": f"{cookie_name(port)}={new_token()}"},
    }
    statuses = {name: handshake(port, headers) for name, headers in refused.items()}
    assert statuses == {
        "foreign origin": 403,
        "another local port": 403,
        "null origin": 403,
        "wrong host": 403,
        "no token": 401,
        "wrong token": 401,
    }
    assert handshake(port, good) == 101
    assert handshake(port, {}, f"?token={web.policy.token}") == 101  # a scripted client


def test_a_share_tunnel_cannot_be_requested(web: GuardedServer) -> None:
    """A client's ShareUrlRequest would publish the studio on share.viser.studio."""
    handlers = web.server._websock_server._incoming_handlers
    assert viser_messages.ShareUrlRequest not in handlers


def test_the_hook_fails_loudly_when_viser_starts_its_server_another_way() -> None:
    plain = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)  # started unhooked
    policy = AccessPolicy("127.0.0.1", new_token())
    with pytest.raises(ViserHookError, match="refuses to serve"):
        hooked_viser_server(lambda: plain, guard_requests(policy))
    with pytest.raises(OSError):  # and the unguarded server was stopped
        http_get(plain.get_port())


# --- uploads ---------------------------------------------------------------------------


class Button:
    """An upload button and what it received; `wait(n)` returns once n more uploads arrived."""

    def __init__(self, server: viser.ViserServer) -> None:
        handle = server.gui.add_upload_button("Upload")
        self.uuid: str = handle._impl.uuid  # what a client reads from the button's message
        self.received: list[bytes] = []
        self._done = threading.Semaphore(0)

        @handle.on_upload
        def _(_event) -> None:
            self.received.append(handle.value.content)
            self._done.release()

    def wait(self, n: int = 1) -> bool:
        return all(self._done.acquire(timeout=120) for _ in range(n))


@pytest.fixture
def button(web: GuardedServer) -> Button:
    """A fresh button per test: an upload still finishing from another test cannot count."""
    return Button(web.server)


HONEST = bytes(range(256)) * 3000  # 768 000 bytes, two parts


def hostile_then_honest(web: GuardedServer, button: Button, hostile: list[bytes], n: int = 1):
    """Send `hostile` frames then an honest upload on one websocket; once `n` uploads
    arrived (frames of one tab are handled in order), return (honest upload arrived
    intact, bytes of unfinished uploads still held), measured with the tab still open."""
    cookie = own(web)["Cookie"]
    frames = hostile + honest_upload(button.uuid, HONEST)
    arrived, held = stream(
        web.server.get_port(), cookie, frames, lambda: (button.wait(n), web.uploads.held_bytes())
    )
    return arrived and HONEST in button.received[-n:], held


def test_an_honest_upload_passes(web: GuardedServer, button: Button) -> None:
    assert hostile_then_honest(web, button, []) == (True, 0)


def test_a_declared_oversize_upload_is_dropped_at_the_start(
    web: GuardedServer, button: Button
) -> None:
    transfer = uuid.uuid4().hex
    frames = [start_frame(button.uuid, 4 * 10**9, 8000, transfer)]
    frames += [part_frame(button.uuid, transfer, i, b"\0" * 400_000) for i in range(5)]
    dropped = len(web.uploads.dropped)
    assert hostile_then_honest(web, button, frames) == (True, 0)
    assert [d.reason for d in web.uploads.dropped[dropped:]] == [
        "'robot.zip' is 4000.0 MB; uploads are limited to 1.0 MB"
    ]


def oversize_stream(button_uuid: str) -> list[bytes]:
    """Declared at the limit, then ten times more sent in 0.4 MB parts."""
    transfer = uuid.uuid4().hex
    frames = [start_frame(button_uuid, LIMIT, LIMIT // 1024, transfer)]
    return frames + [part_frame(button_uuid, transfer, i, b"\1" * 400_000) for i in range(25)]


def test_an_upload_streaming_past_its_size_is_dropped(web: GuardedServer, button: Button) -> None:
    dropped = len(web.uploads.dropped)
    assert hostile_then_honest(web, button, oversize_stream(button.uuid)) == (True, 0)
    assert len(web.uploads.dropped) == dropped + 1
    assert "sent 1.2 MB" in web.uploads.dropped[-1].reason  # dropped at the third part


def test_the_same_stream_is_held_whole_by_an_unguarded_viser() -> None:
    """The control: a plain viser keeps every byte (so the test above can fail)."""
    plain = viser.ViserServer(host="127.0.0.1", port=0, verbose=False)
    try:
        button = Button(plain)
        states = plain.gui._current_file_upload_states

        def held() -> tuple[bool, int]:
            arrived = button.wait()
            parts = [p for s in list(states.values()) for p in s["parts"].values()]
            return arrived, sum(len(p) for p in parts)

        frames = oversize_stream(button.uuid) + honest_upload(button.uuid, HONEST)
        assert stream(plain.get_port(), "", frames, held) == (True, 25 * 400_000)
    finally:
        plain.stop()


def test_at_most_two_unfinished_uploads_per_tab(web: GuardedServer, button: Button) -> None:
    transfers = [uuid.uuid4().hex for _ in range(3)]
    frames = [start_frame(button.uuid, 1000, 1, t) for t in transfers]  # three open at once
    frames.append(part_frame(button.uuid, transfers[0], 0, b"x" * 1000))  # the first ends
    dropped = len(web.uploads.dropped)
    arrived, held = hostile_then_honest(web, button, frames, n=2)
    # Both the finished upload and the honest one arrived (viser's callbacks read the button's
    # last value, so which content each callback saw depends on the thread pool's timing).
    assert (arrived, held, len(button.received)) == (True, 0, 2)
    assert [d.reason for d in web.uploads.dropped[dropped:]] == [
        "more than 2 uploads at once from this tab; wait for one to finish"
    ]


def test_many_tabs_cannot_add_up_past_the_total(web: GuardedServer, button: Button) -> None:
    """Two tabs keep two 1 MB uploads open each (the 4 MB total); a third tab's start is
    refused, its empty upload (sent next) still passes."""
    port, cookie = web.server.get_port(), own(web)["Cookie"]

    def starts(n: int) -> list[bytes]:
        return [start_frame(button.uuid, LIMIT, 1, uuid.uuid4().hex) for _ in range(n)]

    def then_empty(frames: list[bytes], then: Callable[[], bool]) -> Callable[[], bool]:
        """A tab sending `frames` then an empty upload (viser finishes it at once); once
        that arrived (so were `frames`), run `then` with the tab still open."""
        empty = start_frame(button.uuid, 0, 0, uuid.uuid4().hex)
        return lambda: stream(port, cookie, [*frames, empty], lambda: button.wait() and then())

    dropped = len(web.uploads.dropped)
    third_tab = then_empty(starts(1), lambda: True)
    second_tab = then_empty(starts(2), third_tab)
    assert then_empty(starts(2), second_tab)()
    assert button.received[-1] == b""
    assert [d.reason for d in web.uploads.dropped[dropped:]] == [
        "the studio is already receiving 4.0 MB of uploads; try again when they finish"
    ]


def test_a_flood_of_tiny_parts_is_refused(web: GuardedServer, button: Button) -> None:
    transfer = uuid.uuid4().hex
    dropped = len(web.uploads.dropped)
    start = start_frame(button.uuid, 10_000, 10**6, transfer)
    assert hostile_then_honest(web, button, [start]) == (True, 0)
    assert "parts; refused as malformed" in web.uploads.dropped[dropped].reason


SERVER_SCRIPT = """
import sys
from app.web.guard import guarded_server
web = guarded_server("127.0.0.1", 0, "{token}", max_upload_bytes={limit})
button = web.server.gui.add_upload_button("Upload")
button.on_upload(lambda event: print("uploaded", len(button.value.content), flush=True))
print("ready", web.server.get_port(), button._impl.uuid, flush=True)
sys.stdin.read()
"""


def _next(stdout: IO[str], first_word: str) -> list[str]:
    """The next line of the server's output that starts with `first_word` (viser prints too)."""
    for line in stdout:
        if line.split()[:1] == [first_word]:
            return line.split()[1:]
    raise AssertionError(f"the server exited before printing {first_word!r}")


def _peak_rss_bytes(pid: int) -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) * 1024
    raise AssertionError("no VmHWM in /proc status")


@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="needs Linux /proc")
def test_a_200_mb_stream_does_not_grow_the_server(tmp_path: Path) -> None:
    """The server (its own process) streams 200 MB of a transfer declared at 2 MB: its
    peak resident memory grows by far less than the stream."""
    token = new_token()
    script = SERVER_SCRIPT.format(token=token, limit=2_000_000)
    server = subprocess.Popen(
        [sys.executable, "-c", script],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        cwd=Path(__file__).resolve().parents[1],
    )
    try:
        assert server.stdout is not None
        stdout = server.stdout
        port_text, uuid_ = _next(stdout, "ready")
        port = int(port_text)
        cookie = f"{cookie_name(port)}={token}"

        def uploaded() -> list[str]:
            return _next(stdout, "uploaded")

        warm_up = honest_upload(uuid_, b"warm-up" * 100_000)
        assert stream(port, cookie, warm_up, uploaded) == ["700000"]
        baseline = _peak_rss_bytes(server.pid)
        transfer = uuid.uuid4().hex
        frames = [start_frame(uuid_, 2_000_000, 1953, transfer)]
        frames += [part_frame(uuid_, transfer, i, b"\2" * 1_000_000) for i in range(200)]
        frames += honest_upload(uuid_, b"after" * 1000)
        assert stream(port, cookie, frames, uploaded) == ["5000"]
        growth = _peak_rss_bytes(server.pid) - baseline
        assert growth < 60e6, f"server peak memory grew by {growth / 1e6:.0f} MB"
    finally:
        server.kill()
        server.wait()


# --- through the studio and the CLI ----------------------------------------------------


def _free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def test_the_studio_serves_only_its_tokened_link(tmp_path: Path) -> None:
    from app.config import StudioConfig
    from app.studio import Studio

    studio = Studio(StudioConfig(port=_free_port(), data_dir=tmp_path))
    config = studio.config  # its token settled: the one kept in the data folder
    try:
        assert config.token is not None and (tmp_path / "access-token").read_text().strip() == (
            config.token
        )
        port = studio.web.server.get_port()
        assert studio.web.url == f"http://127.0.0.1:{port}/?token={config.token}"
        assert http_get(port, "/")[0] == 401
        assert http_get(port, f"/?token={config.token}")[0] == 200
        foreign = {
            "Origin": "http://evil.example.com",
            "Cookie": f"{cookie_name(port)}={config.token}",
        }
        assert handshake(port, foreign) == 403
    finally:
        studio.stop()


def test_the_studio_refuses_no_token_beyond_loopback(tmp_path: Path) -> None:
    from app.config import StudioConfig
    from app.studio import Studio

    with pytest.raises(InsecureServeError):
        Studio(StudioConfig(host="0.0.0.0", port=_free_port(), data_dir=tmp_path, no_token=True))


def test_serve_refuses_no_token_on_the_network_before_starting() -> None:
    cli = subprocess.run(
        [sys.executable, "-m", "app", "serve", "--host", "0.0.0.0", "--no-token"],
        capture_output=True,
        text=True,
        cwd=Path(__file__).resolve().parents[1],
        timeout=300,
    )
    assert cli.returncode == 1
    assert "--no-token with --host 0.0.0.0" in cli.stderr
    assert "http://" not in cli.stdout
