"""Sharing from the studio: *Export replay* records the current motion as shown (robot, the
ghosts and traces that are on, a title card) into a folder that plays in any browser, and
*Screenshot* saves a tab's render as a PNG. Both write under the data folder.

The recording is drawn on a private viser server (app/replay_recorder.py): the live tabs see
nothing of it. An export runs in one named thread, "replay-export"; its end is announced by
`exported` (the result, or None after a failure), a screenshot's by `screenshot_saved`.
"""

from __future__ import annotations

import logging
import re
import threading
import time
from collections.abc import Callable
from pathlib import Path

import imageio.v3 as iio
import numpy as np
import viser

from app.core.errors import StudioError
from app.core.motions.trajectory import Trajectory
from app.core.replay.scene import ReplayLayers, replay_scene, title_card
from app.core.robot.model import RobotModel
from app.replay_recorder import RecordedReplay, export_replay
from app.studio.notifier import Notifier
from app.studio.signals import Signal
from app.studio.state import StudioState
from panels.share_panel import SharePanel

log = logging.getLogger(__name__)

MAX_SCREENSHOT_SIDE = 4096


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "-", text).strip("-.")[:60] or "untitled"


def on_white(image: np.ndarray) -> np.ndarray:
    """An RGBA render (transparent where nothing is drawn) over the studio's white page, RGB."""
    if image.ndim != 3 or image.shape[2] != 4:
        return image
    alpha = image[..., 3:4].astype(np.float32) / 255.0
    rgb = image[..., :3].astype(np.float32) * alpha + 255.0 * (1.0 - alpha)
    return np.round(rgb).astype(np.uint8)


class ShareSession:
    """Owns the Share panel; `layers()` says what the studio shows beside the robot."""

    def __init__(
        self,
        server: viser.ViserServer,
        state: StudioState,
        notifier: Notifier,
        data_dir: Path,
        layers: Callable[[], ReplayLayers],
    ) -> None:
        self._server, self._state, self._notifier = server, state, notifier
        self._data_dir, self._layers = Path(data_dir), layers
        self.panel = SharePanel(server.gui, self)
        self._worker: threading.Thread | None = None
        self.exported: Signal[RecordedReplay | None] = Signal("replay_exported")
        self.screenshot_saved: Signal[Path | None] = Signal("screenshot_saved")

    # --- replay ----------------------------------------------------------------------------

    def export_replay(self, client: viser.ClientHandle | None = None) -> None:
        """Start recording the current motion in the "replay-export" thread."""
        with self._state.lock:
            robot, trajectory = self._state.robot, self._state.trajectory
        if robot is None or trajectory is None:
            self._fail("Nothing to export", "generate or build a motion first", client)
            self.exported.emit(None)
            return
        if self._worker is not None and self._worker.is_alive():
            self._notifier.notify("Export running", "one replay at a time", client, "yellow")
            return
        out = (
            self._data_dir
            / "replays"
            / (f"{_slug(robot.name)}-{_slug(trajectory.name)}-{time.strftime('%Y%m%d-%H%M%S')}")
        )
        layers = self._layers()
        make_zip = bool(self.panel.zip.value)
        self.panel.show_progress(0.0)
        self.panel.status.content = f"Recording **{trajectory.name}**…"
        self._worker = threading.Thread(
            target=self._export,
            args=(robot, trajectory, layers, out, make_zip, client),
            name="replay-export",
            daemon=True,
        )
        self._worker.start()

    def _export(
        self,
        robot: RobotModel,
        trajectory: Trajectory,
        layers: ReplayLayers,
        out: Path,
        make_zip: bool,
        client: viser.ClientHandle | None,
    ) -> None:
        result: RecordedReplay | None = None
        try:
            title = title_card(
                robot.name, trajectory.name, trajectory.duration, layers.parameters, layers.verdicts
            )
            scene = replay_scene(
                robot,
                trajectory,
                title,
                layers.prediction,
                ghosts=layers.ghosts,
                extra_ghosts=layers.extra_ghosts,
                traces=layers.traces,
            )
            result = export_replay(robot, scene, out, make_zip, progress=self.panel.show_progress)
        except StudioError as error:
            self._fail("Replay export failed", str(error), client)
        except Exception as error:  # a bug: say so in the panel, and still announce the end
            log.exception("replay export")
            self._fail("Replay export failed", f"{type(error).__name__}: {error}", client)
        finally:
            self.panel.show_progress(None)
        if result is not None:
            folder = result.folder
            zipped = f" and `{folder.zip_path}`" if folder.zip_path is not None else ""
            self.panel.status.content = (
                f"Replay of **{trajectory.name}** ({result.n_frames} frames, "
                f"{folder.total_bytes / 1e6:.1f} MB) in `{folder.path}`{zipped}.  \n"
                f"Open it with `biped-studio replay open {folder.path}`, or serve the folder "
                "with any static web server."
            )
            self._notifier.notify("Replay exported", str(folder.path), client)
        self.exported.emit(result)

    # --- screenshot ------------------------------------------------------------------------

    def screenshot(self, client: viser.ClientHandle | None = None) -> None:
        """Save what `client` renders now as a PNG under the data folder."""
        path: Path | None = None
        try:
            if client is None:
                raise StudioError("a screenshot is taken from a browser tab; none asked")
            height = min(int(client.camera.image_height), MAX_SCREENSHOT_SIDE)
            width = min(int(client.camera.image_width), MAX_SCREENSHOT_SIDE)
            if height <= 0 or width <= 0:
                raise StudioError("the tab has not drawn the scene yet")
            image = client.get_render(height, width, transport_format="png", timeout=60.0)
            folder = self._data_dir / "screenshots"
            folder.mkdir(parents=True, exist_ok=True)
            name = self._state.trajectory.name if self._state.trajectory is not None else "pose"
            path = folder / f"{_slug(name)}-{time.strftime('%Y%m%d-%H%M%S')}-{client.client_id}.png"
            iio.imwrite(path, on_white(image))
            self.panel.status.content = f"Screenshot ({width}×{height}) saved to `{path}`."
            self._notifier.notify("Screenshot saved", str(path), client)
        except (StudioError, OSError, TimeoutError) as error:
            path = None
            self._fail("Screenshot failed", str(error), client)
        self.screenshot_saved.emit(path)

    def _fail(self, title: str, body: str, client: viser.ClientHandle | None) -> None:
        self.panel.status.content = f"⚠️ {title}: {body}"
        self._notifier.error(title, body, client)

    def close(self) -> None:
        worker = self._worker
        if worker is not None:
            worker.join()
