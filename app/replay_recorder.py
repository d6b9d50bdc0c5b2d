"""Record a replay with viser's scene serializer, on a private viser server.

viser 1.1 records only what a server sends (`ViserServer.get_scene_serializer` taps the
server's outgoing messages); it has no serializer that draws without a server. So that a
recording never reaches the live studio's tabs, it is drawn on a second viser server of its
own: bound to 127.0.0.1 on a free port, behind a random token nobody is given, stopped when
the recording is done. The live scene is not touched.
"""

from __future__ import annotations

import contextlib
import dataclasses
import importlib.util
import secrets
import sys
import time
from collections.abc import Callable
from pathlib import Path

import viser
from viser.infra import StateSerializer

from app.core.replay.folder import ReplayFolder, check_replay_target, write_replay_folder
from app.core.replay.legend import legend_html
from app.core.replay.scene import ReplayError, ReplayScene
from app.core.robot.model import RobotModel
from app.views.ghosts_view import GHOSTS, OPACITY
from app.views.robot_view import RobotView
from app.views.traces_view import TracesView
from app.web.guard import guarded_server


@dataclasses.dataclass(frozen=True)
class RecordedReplay:
    folder: ReplayFolder
    n_frames: int
    duration_s: float
    record_s: float
    """Wall time spent drawing and serializing [s]."""


def viser_client_html() -> Path:
    """viser's built web client: one self-contained page."""
    spec = importlib.util.find_spec("viser")
    if spec is None or spec.origin is None:
        raise ReplayError("viser is not installed")
    page = Path(spec.origin).parent / "client" / "build" / "index.html"
    if not page.is_file():
        raise ReplayError(f"viser's built client is missing ({page})")
    return page


def legend(scene: ReplayScene) -> str:
    """The page's title card and legend: each ghost shown, with a swatch of its colour."""
    return legend_html(scene.title, [GHOSTS[name] for name in scene.ghosts])


def private_server() -> viser.ViserServer:
    """A viser server nobody can reach: 127.0.0.1, a free port, a token nobody is given."""
    with contextlib.redirect_stdout(sys.stderr):  # viser's banner is not our output
        web = guarded_server(
            "127.0.0.1", 0, secrets.token_urlsafe(24), label="replay", max_upload_bytes=1
        )
    return web.server


def record(
    robot: RobotModel, scene: ReplayScene, progress: Callable[[float], None] | None = None
) -> bytes:
    """The `.viser` recording of the scene: built once, then one frame every frame_dt_s."""
    server = private_server()
    try:
        # One atomic block around the whole recording: no tab is there to be woken per message.
        with server.atomic():
            server.scene.set_up_direction("+z")
            serializer = server.get_scene_serializer()
            draw_scene(server, robot, scene, serializer, progress)
        data = serializer.serialize()
    finally:
        with contextlib.redirect_stdout(sys.stderr):
            server.stop()
    return data


def draw_scene(
    server: viser.ViserServer,
    robot: RobotModel,
    scene: ReplayScene,
    serializer: StateSerializer | None,
    progress: Callable[[float], None] | None = None,
) -> None:
    """Draw the scene on `server` and show its frames back to back; with a serializer, one
    frame every frame_dt_s of the recording's clock."""
    server.initial_camera.position = scene.camera_position_m
    server.initial_camera.look_at = scene.camera_look_at_m
    server.scene.add_grid(
        "/ground", width=4.0, height=4.0, cell_size=0.1, section_size=0.5, plane="xy"
    )
    # The full card and legend are the page's (app.core.replay.legend); in 3D, the title only.
    heading = scene.title.splitlines()[0] if scene.title else ""
    if heading:
        server.scene.add_label(
            "/title", heading, position=scene.title_position_m, anchor="bottom-center"
        )
    if scene.paths:
        TracesView(server, scene.paths, root="/traces")
    robot_view = RobotView(server, robot, root="/robot", with_collision=False)
    ghosts = {
        name: RobotView(
            server,
            robot,
            root=f"/ghosts/{name}",
            tint_rgb=GHOSTS[name][0],
            opacity=OPACITY,
            with_collision=False,
        )
        for name in scene.ghosts
    }
    for f in range(scene.n_frames):
        if f and serializer is not None:
            serializer.insert_sleep(scene.frame_dt_s)
        robot_view.update(scene.q_robot[f])
        for name, view in ghosts.items():
            view.update(scene.ghosts[name][f])
        if progress is not None and f % 30 == 0:
            progress(0.9 * f / scene.n_frames)


def export_replay(
    robot: RobotModel,
    scene: ReplayScene,
    out: Path,
    make_zip: bool = False,
    progress: Callable[[float], None] | None = None,
    force: bool = False,
) -> RecordedReplay:
    """Record the scene and write the replay folder at `out` (ReplayError on bad output,
    before anything is recorded)."""
    check_replay_target(out, make_zip, force)
    client = viser_client_html()
    start = time.perf_counter()
    data = record(robot, scene, progress)
    manifest = {
        "robot": robot.name,
        "duration_s": scene.duration_s,
        "n_frames": scene.n_frames,
        "frame_dt_s": scene.frame_dt_s,
        "ghosts": list(scene.ghosts),
        "traces": bool(scene.paths),
        "viser_version": viser.__version__,
    }
    folder = write_replay_folder(
        out, data, client, scene.title, manifest, make_zip, force, overlay=legend(scene)
    )
    if progress is not None:
        progress(1.0)
    return RecordedReplay(folder, scene.n_frames, scene.duration_s, time.perf_counter() - start)
