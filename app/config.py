"""The studio's configuration: one frozen object, the single source for the CLI and the UI."""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

from app.core.robot.uploads import MAX_UPLOAD_BYTES
from app.web.token_store import stored_token
from robots.catalogue import DEFAULT_ROBOT

LOCAL_HOSTS = ("127.0.0.1", "localhost", "::1")


def default_data_dir() -> Path:
    """Where uploads live: $BIPED_STUDIO_DATA, else ~/.local/share/biped-studio."""
    env = os.environ.get("BIPED_STUDIO_DATA")
    return Path(env) if env else Path.home() / ".local" / "share" / "biped-studio"


@dataclasses.dataclass(frozen=True)
class StudioConfig:
    robot: str = DEFAULT_ROBOT
    """Built-in robot name or URDF path to open at start."""
    host: str = "127.0.0.1"
    """Interface to serve on. Local only unless the user asks; viser's own default is 0.0.0.0."""
    port: int = 8080
    package_roots: tuple[Path, ...] = ()
    """Extra folders in which to look for package://NAME folders."""
    feet: tuple[str, str] | None = None
    """(left, right) foot links, overriding detection."""
    allow: tuple[Path, ...] = ()
    """Folders besides the working folder, the built-ins, the package roots and the upload
    store whose files *Open path* may load (`--allow DIR`)."""
    data_dir: Path = dataclasses.field(default_factory=default_data_dir)
    max_upload_bytes: int = MAX_UPLOAD_BYTES
    token: str | None = dataclasses.field(default=None, repr=False)
    """Access token a browser must present (`?token=` once, then a cookie). None: the one kept
    in `data_dir` (app.web.token_store), made at the first start and reused after, so open
    tabs survive a restart; `settle_token()` fills it in."""
    new_token: bool = False
    """Replace the kept token with a new one (`--new-token`): links opened before stop working."""
    prepare_gait: bool = False
    """Build the gait planner's default problem for each loaded robot in the background, so
    the first *Solve* pays no build (`serve` turns it on; tests and the bench leave it off)."""
    prepare_sweep: bool = False
    """Start the sweep cluster and build the swept robot's NLP on its workers in the background
    (low priority) when a robot loads, so a sweep's first point pays only its solve (`serve`
    turns it on; tests and the bench leave it off unless they time it)."""
    no_token: bool = False
    """Serve without the token (`--no-token`): loopback only, refused on other hosts."""

    project: Path | None = None
    """A .bstudio project to open at start (`--project FILE`), replacing `robot`."""
    restore_autosave: bool = False
    """Restore the newest autosave at start (serve does, unless --project, --robot or --fresh)."""
    autosave: bool = True
    """Save the work to data_dir/autosave/ after every change."""
    presenter_only: bool = False
    """Only the oldest open tab may change the work (`--presenter-only`); others only watch."""

    @property
    def access_token(self) -> str | None:
        """The token the server requires, None when the user turned it off."""
        if self.no_token:
            return None
        if self.token is None:  # never read as "no token": that would open the studio
            raise ValueError("the access token is not settled yet: call settle_token() first")
        return self.token

    def settle_token(self) -> tuple[StudioConfig, str]:
        """This config with its token filled in (the one kept in `data_dir`, made there when
        there is none or `new_token` asks), and one line for the user ("" when nothing needs
        saying: the stored token was refused and replaced, or cannot be kept)."""
        if self.no_token or self.token is not None:
            return self, ""
        stored = stored_token(self.data_dir, rotate=self.new_token)
        return dataclasses.replace(self, token=stored.token), stored.warning

    @property
    def uploads_dir(self) -> Path:
        return self.data_dir / "uploads"

    @property
    def is_local(self) -> bool:
        return self.host in LOCAL_HOSTS
