"""The studio's configuration: one frozen object, the single source for the CLI and the UI."""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

from app.core.robot.uploads import MAX_UPLOAD_BYTES
from app.web.access import new_token
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
    token: str = dataclasses.field(default_factory=new_token, repr=False)
    """Access token a browser must present (`?token=` once, then a cookie); random per run."""
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
        return None if self.no_token else self.token

    @property
    def uploads_dir(self) -> Path:
        return self.data_dir / "uploads"

    @property
    def is_local(self) -> bool:
        return self.host in LOCAL_HOSTS
