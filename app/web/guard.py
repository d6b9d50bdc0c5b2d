"""The studio's web server with its door locked: the one call the studio makes.

    web = guarded_server(host, port, token, max_upload_bytes=...)
    server = web.server

holds a started `viser.ViserServer` whose every HTTP request and websocket handshake passes the
Host / Origin / token checks of `app.web.access` before viser sees it (hooked by
`app.web.hook`), whose pages cannot be framed, and whose uploads are bounded while
they stream (`app.web.upload_limits`). viser's share-tunnel request (a client asking the
server to publish itself on share.viser.studio) is unregistered: no client can put the
studio on the internet. An upload's progress goes to the tab that uploads, not to every tab
(`send_upload_receipts_to_their_tab`). `token=None` turns the token off; that is
refused on any non-loopback bind (`app.web.access.InsecureServeError`).
"""

from __future__ import annotations

import contextlib
import dataclasses
import sys

import viser

from app.web.access import AccessPolicy, check_bind, studio_url
from app.web.hook import guard_requests, hooked_viser_server
from app.web.upload_limits import MAX_UNFINISHED_UPLOADS, UploadGuard, UploadLimits
from app.web.viser_internals import refuse_share_tunnel, send_upload_receipts_to_their_tab

__all__ = ["GuardedServer", "guarded_server"]


@dataclasses.dataclass(frozen=True)
class GuardedServer:
    """A running viser server and the guards around it."""

    server: viser.ViserServer
    policy: AccessPolicy
    uploads: UploadGuard

    @property
    def url(self) -> str:
        """The URL to open (with `?token=` unless the token is off)."""
        return studio_url(self.server.get_host(), self.server.get_port(), self.policy.token)


def guarded_server(
    host: str,
    port: int,
    token: str | None,
    *,
    label: str | None = None,
    verbose: bool = False,
    max_upload_bytes: int,
    max_unfinished_uploads: int = MAX_UNFINISHED_UPLOADS,
    extra_hosts: tuple[str, ...] = (),
) -> GuardedServer:
    """A started viser server on `host`:`port` that only answers its own page holding `token`.

    viser moves to the next free port when `port` is taken: read the port (or `url`)
    from the result.
    """
    check_bind(host, token)
    policy = AccessPolicy(bound_host=host, token=token, extra_hosts=extra_hosts)
    # viser prints a banner with the link *without* the token; the studio prints its own
    # tokened link, so the banner goes to stderr (stdout stays clean for --json output).
    with contextlib.redirect_stdout(sys.stderr):
        server = hooked_viser_server(
            lambda: viser.ViserServer(host=host, port=port, label=label, verbose=verbose),
            guard_requests(policy),
        )
    refuse_share_tunnel(server)
    send_upload_receipts_to_their_tab(server)
    uploads = UploadGuard(server, UploadLimits(max_upload_bytes, max_unfinished_uploads))
    return GuardedServer(server, policy, uploads)
