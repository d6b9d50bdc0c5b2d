"""Who may talk to the studio's web server: Host, Origin and access-token checks.

Pure policy over one HTTP request (path + headers + the port the request arrived on);
`app.web.hook` applies it to every request viser's server receives, the websocket
handshake included, before viser sees the request.

Rules, in order (the first failing one refuses the request):

1. **Host** must name this server: `NAME:PORT` with PORT the port the request arrived on
   and NAME a loopback name (`127.0.0.1`, `localhost`, `[::1]`), the bound host, or an
   extra allowed name. On a wildcard bind (`0.0.0.0`, `::`) any IP literal and this
   machine's host names are accepted too: DNS rebinding needs a *domain name* that
   resolves to us, so refusing unknown names stops it while IP addresses stay usable.
2. **Origin**, when the browser sends one, must be `http://` + an allowed Host as above.
   Browsers always send it on websocket handshakes, so a page of another origin (another
   site, or another port of this machine) is refused (cross-site websocket hijacking).
3. **Token**, unless the studio runs with `--no-token`: `?token=…` in the URL or the
   cookie `biped_studio_token_PORT` that the first tokened page load sets (HttpOnly,
   SameSite=Strict). viser's client opens its websocket on the page's URL *without* the
   query string, so the cookie is what carries the token to the websocket. A page load
   without the token gets the short `TOKEN_PAGE`; anything else gets a plain 403.
"""

from __future__ import annotations

import dataclasses
import functools
import hmac
import ipaddress
import secrets
import socket
from collections.abc import Sequence
from http.cookies import CookieError, SimpleCookie
from urllib.parse import parse_qs, urlsplit

from app.core.errors import StudioError

LOOPBACK_NAMES = ("127.0.0.1", "localhost", "[::1]")
WILDCARD_HOSTS = ("0.0.0.0", "::", "")
TOKEN_PARAM = "token"
TOKEN_BYTES = 32
"""`secrets.token_urlsafe(32)`: 256 random bits, 43 URL-safe characters."""

SECURITY_HEADERS = (
    ("X-Frame-Options", "DENY"),
    ("Content-Security-Policy", "frame-ancestors 'none'"),
    ("X-Content-Type-Options", "nosniff"),
    ("Referrer-Policy", "no-referrer"),
)
"""Sent on every HTTP answer: the page cannot be framed (clickjacking), nor leak its URL."""

TOKEN_PAGE = """<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>Biped Studio: access link needed</title></head>
<body style="font-family: sans-serif; max-width: 40em; margin: 4em auto">
<h1>Biped Studio needs its access link</h1>
<p>This studio only answers the link printed in the terminal where it was started,
the one that ends in <code>?token=&hellip;</code>. Open that link in this browser.</p>
<p>Lost it? Stop the studio (Ctrl+C) and start it again: it prints the link again.
If this tab worked before, the studio was started with <code>--new-token</code>, which
makes a new link: open the new one.</p>
</body></html>
"""


class InsecureServeError(StudioError):
    """Serving beyond this machine without the access token is refused."""


def is_loopback(host: str) -> bool:
    """`host` only accepts connections from this machine."""
    return host in ("localhost", "::1", "[::1]") or host.startswith("127.")


def check_bind(host: str, token: str | None) -> None:
    """Refuse `--no-token` on any bind that other machines can reach."""
    if token is None and not is_loopback(host):
        raise InsecureServeError(
            f"--no-token with --host {host} would let anyone who can reach this machine "
            "drive the studio; keep the token (open the printed link) or serve on 127.0.0.1"
        )


def new_token() -> str:
    """A fresh random access token (URL-safe, 256 bits)."""
    return secrets.token_urlsafe(TOKEN_BYTES)


def cookie_name(port: int) -> str:
    """Cookies ignore ports, so two studios on one machine each need their own name."""
    return f"biped_studio_token_{port}"


@dataclasses.dataclass(frozen=True)
class Verdict:
    """What to do with one request. `status` 0 means "let viser answer it"."""

    status: int
    reason: str
    set_cookie: bool = False
    """The request carried a valid `?token=`: answer with the token cookie."""

    @property
    def allowed(self) -> bool:
        return self.status == 0


ALLOW = Verdict(0, "")


@dataclasses.dataclass(frozen=True)
class AccessPolicy:
    """The studio's web access rules (see the module docstring)."""

    bound_host: str
    """The host the server was asked to bind (`127.0.0.1`, `0.0.0.0`, a name…)."""
    token: str | None
    """The access token, or None when the user explicitly turned it off."""
    extra_hosts: tuple[str, ...] = ()
    """More host names to accept in Host/Origin (e.g. a name the machine is reached by)."""

    def __post_init__(self) -> None:
        if self.token is not None and len(self.token) < 16:
            raise ValueError("an access token must be at least 16 characters")
        _ = self.host_names  # resolve now, not on the server's event loop

    @property
    def wildcard(self) -> bool:
        return self.bound_host in WILDCARD_HOSTS

    @functools.cached_property
    def host_names(self) -> frozenset[str]:
        """Accepted host names (lower case, IPv6 literals in brackets); computed once, as
        `getfqdn` may ask the resolver."""
        names = set(LOOPBACK_NAMES) | {_bracketed(h.lower()) for h in self.extra_hosts}
        if not self.wildcard:
            names.add(_bracketed(self.bound_host.lower()))
        else:
            names |= {socket.gethostname().lower(), socket.getfqdn().lower()}
        return frozenset(names)

    def host_allowed(self, host_header: str | None, port: int) -> bool:
        """Host header `NAME[:PORT]` names this server on `port` (80 when no port given)."""
        if not host_header:
            return False
        name, sep, port_text = host_header.strip().lower().rpartition(":")
        if not sep or name == "" or name.endswith(":") or "]" in port_text:
            name, port_text = host_header.strip().lower(), "80"
        if not port_text.isdigit() or int(port_text) != port:
            return False
        if name in self.host_names:
            return True
        return self.wildcard and _is_ip_literal(name)

    def origin_allowed(self, origin: str, port: int) -> bool:
        """Origin `http://HOST[:PORT]` is this server (a missing Origin is checked by the caller)."""
        parts = urlsplit(origin)
        if parts.scheme != "http" or parts.path not in ("", "/") or parts.query:
            return False
        return self.host_allowed(parts.netloc, port)

    def token_in_url(self, path: str) -> bool:
        """The request path's query carries `token=` equal to the token (constant time)."""
        assert self.token is not None
        query = parse_qs(urlsplit(path).query)
        return any(_same(candidate, self.token) for candidate in query.get(TOKEN_PARAM, []))

    def check(
        self, path: str, headers: Sequence[tuple[str, str]], port: int, websocket: bool
    ) -> Verdict:
        """The verdict for one request that arrived on local `port`.

        `headers` are the request's (name, value) pairs as received; a repeated Host or
        Origin is refused (two values leave it open which one a proxy or check uses).
        A page load refused only for the token gets `TOKEN_PAGE` from the caller.
        """
        hosts = _values(headers, "Host")
        host = hosts[0] if len(hosts) == 1 else None
        if not self.host_allowed(host, port):
            return Verdict(403, f"Host {', '.join(hosts)!r} is not this studio")
        origins = _values(headers, "Origin")
        if len(origins) > 1 or (origins and not self.origin_allowed(origins[0], port)):
            return Verdict(403, f"Origin {', '.join(origins)!r} is not this studio")
        if self.token is None:
            return ALLOW
        if self.token_in_url(path):
            return Verdict(0, "", set_cookie=not websocket)
        cookies = "; ".join(_values(headers, "Cookie"))
        if _cookie_matches(cookies, cookie_name(port), self.token):
            return ALLOW
        return Verdict(401, "missing or wrong access token")

    def cookie_header(self, port: int) -> str:
        """The Set-Cookie value that carries the token to the websocket and later loads."""
        assert self.token is not None
        return f"{cookie_name(port)}={self.token}; Path=/; HttpOnly; SameSite=Strict"


def studio_url(host: str, port: int, token: str | None) -> str:
    """The URL to open: loopback for wildcard binds, with `?token=` when there is one."""
    shown = "127.0.0.1" if host in WILDCARD_HOSTS else _bracketed(host)
    return f"http://{shown}:{port}/" + (f"?{TOKEN_PARAM}={token}" if token else "")


def _values(headers: Sequence[tuple[str, str]], name: str) -> list[str]:
    return [value for key, value in headers if key.lower() == name.lower()]


def _same(candidate: str, token: str) -> bool:
    return hmac.compare_digest(candidate.encode(), token.encode())


def _cookie_matches(cookies: str, name: str, token: str) -> bool:
    jar: SimpleCookie = SimpleCookie()
    try:
        jar.load(cookies)
    except CookieError:
        return False
    morsel = jar.get(name)
    return morsel is not None and _same(morsel.value, token)


def _bracketed(host: str) -> str:
    """IPv6 literals appear in brackets in Host and Origin headers."""
    return f"[{host}]" if ":" in host and not host.startswith("[") else host


def _is_ip_literal(name: str) -> bool:
    try:
        ipaddress.ip_address(name.strip("[]"))
    except ValueError:
        return False
    return True
