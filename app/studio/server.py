"""The studio: one viser server, its theme, camera and notifications, the shared state, and one
session per feature. It holds no feature state of its own.

Where things go: a new feature is a session module beside the others (its panel in `panels/`,
its overlays in `app/views/`), constructed here, talking only to the state.
"""

from __future__ import annotations

import contextlib
import io
import logging
from dataclasses import dataclass

from app.config import StudioConfig
from app.core.projects.codec import ProjectError
from app.core.robot.loading import load_robot
from app.core.robot.model import RobotModel
from app.core.robot.report import robot_report
from app.studio.camera_session import CameraSession
from app.studio.compensation_session import CompensationSession
from app.studio.demo_session import DemoSession
from app.studio.gait_session import GaitSession
from app.studio.ghosts_session import GhostsSession
from app.studio.joints_session import JointsSession
from app.studio.motion_session import MotionSession
from app.studio.notifier import Notifier
from app.studio.pipeline_progress import PipelineProgress
from app.studio.playback_session import PlaybackSession
from app.studio.pose_session import PoseSession
from app.studio.project_session import ProjectSession
from app.studio.robot_session import RobotSession, prepare
from app.studio.servo_work import ServoWork
from app.studio.servos_session import ServosSession
from app.studio.share_session import ShareSession
from app.studio.simulation_session import SimulationSession
from app.studio.state import StudioState
from app.studio.sweep_session import SweepSession
from app.studio.torques_session import TorquesSession
from app.web.callback_guard import guard_callbacks
from app.web.guard import GuardedServer, guarded_server
from panels.compensation_folder import CompensationFolder

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class ServoRooms:
    """The servo rooms: torques, coefficients and simulation each fill their rows of the one
    Compensation folder, ghosts draws their results; the servo parts have the Servos panel.
    Each reads the others' results from `state.work` only."""

    torques: TorquesSession
    compensation: CompensationSession
    simulation: SimulationSession
    ghosts: GhostsSession
    servos: ServosSession


@dataclass(frozen=True)
class Presenting:
    """What the tabs and an audience see: each tab's camera (kept for projects), the demo tour
    and its presenter-only gate, and the Share panel (screenshots, videos, replays)."""

    camera: CameraSession
    demo: DemoSession
    share: ShareSession


class Studio:
    """A running studio. All browser tabs share its state."""

    def __init__(self, config: StudioConfig, robot: RobotModel | None = None) -> None:
        config, warning = config.settle_token()  # the token kept in the data folder
        if warning:
            log.warning("%s", warning)
        self.config = config
        """The configuration served, its access token filled in."""
        self.web = _themed_server(config)
        """The viser server behind the Host/Origin/token checks (app.web), and its URL."""
        server = self.web.server
        self.notifier = Notifier(server)
        # No silent failure: whatever a tab's action raises reaches that tab in one line.
        guard_callbacks(server, self.notifier.error)
        self.state = StudioState()
        state, notifier = self.state, self.notifier
        self.robots = RobotSession(server, state, notifier, config)
        self.pose = PoseSession(server, state, notifier)
        self.joints = JointsSession(server, state)
        self.motions = MotionSession(server, state, notifier)
        self.playback = PlaybackSession(server, state)
        camera = CameraSession(server, state)
        # Torques, coefficients and simulation each fill their rows of one Compensation folder.
        folder = CompensationFolder(server.gui)
        compensation = CompensationSession(state, notifier, folder)
        torques = TorquesSession(state, notifier, folder)
        simulation = SimulationSession(state, notifier, folder)
        ghosts = GhostsSession(server, state, folder)
        self.gait = GaitSession(
            server, state, notifier, config.package_roots, prepare=config.prepare_gait
        )
        servos = ServosSession(
            server,
            state,
            notifier,
            gaits=lambda: {
                "symmetric gait": self.gait.results.symmetric,
                "baseline gait": self.gait.results.baseline,
            },
        )
        self.pipeline = PipelineProgress(
            server.gui,
            self.gait.panel.folder,
            state,
            {
                "started": self.gait.pipeline_started,
                "iteration": self.gait.progressed,
                "solved": self.gait.finished,
                "torques": torques.done,
                "simulated": simulation.runner.finished,
                "refused": simulation.refused,
            },
        )
        self.servo_rooms = ServoRooms(torques, compensation, simulation, ghosts, servos)
        self.presenting = Presenting(
            camera,
            DemoSession(server, presenter_only=config.presenter_only),
            ShareSession(
                server,
                state,
                notifier,
                config.data_dir,
                layers=lambda: ghosts.replay_layers(self.playback.panel.traces.value),
                pause_playback=self.playback.player.pause,
            ),
        )
        self.sweep = SweepSession(
            server,
            state,
            notifier,
            config.data_dir / "variants",
            servos=compensation.set_servos,
            prepare=config.prepare_sweep,
            package_roots=config.package_roots,
        )
        if robot is None:
            robot = load_robot(config.robot, package_roots=config.package_roots, feet=config.feet)
            prepare(robot)
        with self.state.lock, server.atomic():
            self.state.set_robot(robot, robot_report(robot))
        self.project = ProjectSession(
            server,
            state,
            notifier,
            config,
            (self.motions, ServoWork(state), self.gait, self.sweep),
            self.motions,
            dragging=lambda: self.pose.handles is not None and bool(self.pose.handles.held),
            servos=servos,
        )
        self._open_first_project(config)
        self.sweep.workers.start_preparing()  # started: prepare the sweep workers in the background

    def _open_first_project(self, config: StudioConfig) -> None:
        """The project asked for on the command line, or the autosave to restore; autosaving."""
        if config.project is not None:
            if not self.project.open(config.project, trusted=True):
                self.stop()
                raise ProjectError(self.project.last_error)
        elif config.restore_autosave:
            self.project.restore_autosave()
        if config.autosave:
            self.project.start_autosave(now=config.project is not None)

    def stop(self) -> None:
        self.project.stop()
        self.playback.stop()
        self.presenting.camera.stop()
        self.presenting.share.close()
        self.gait.close()
        self.sweep.close()
        self.servo_rooms.ghosts.close()
        self.servo_rooms.simulation.close()
        self.servo_rooms.torques.close()
        with contextlib.redirect_stdout(io.StringIO()):  # viser's "Server stopped": not news
            self.web.server.stop()


def _themed_server(config: StudioConfig) -> GuardedServer:
    """The guarded viser server of `config`, with the studio's theme, z up and a ground grid."""
    web = guarded_server(
        config.host,
        config.port,
        config.access_token,
        label="Biped Studio",
        max_upload_bytes=config.max_upload_bytes,
    )
    web.server.gui.configure_theme(control_width="large", dark_mode=False, show_logo=False)
    web.server.scene.set_up_direction("+z")
    web.server.scene.add_grid(
        "/ground",
        width=4.0,
        height=4.0,
        cell_size=0.1,
        section_size=0.5,
        plane="xy",
        shadow_opacity=0.2,
    )
    return web
