"""The robot in the studio: loading (built-in, path, upload), the report, the robot's scene
nodes and which of its layers are drawn.

A load is all or nothing: the robot is parsed, checked and prepared for posing before it is
installed; any failure leaves the previous robot, its pose and its work in place and says why
in the Robot panel and as a notification.
"""

from __future__ import annotations

import dataclasses
import logging
import time
from pathlib import Path

import numpy as np
import viser

from app.config import StudioConfig
from app.core.errors import StudioError
from app.core.file_access import FileAccess
from app.core.posing.drag import Posing
from app.core.robot.loading import load_robot
from app.core.robot.model import RobotModel
from app.core.robot.report import robot_report
from app.core.robot.uploads import store_upload
from app.studio.admission import Admission, Busy
from app.studio.notifier import Notifier, Progress
from app.studio.signals import Signal
from app.studio.state import Display, LoadedRobot, Pose, StudioState
from app.views.lighting import Lighting
from app.views.robot_view import RobotView
from app.views.roots import AlternatingRoot
from panels.display_panel import DisplayFlags, DisplayPanel
from panels.robot_panel import RobotPanel

log = logging.getLogger(__name__)


class RobotSession:
    """Owns the Robot and Display panels and the robot's scene nodes."""

    def __init__(
        self,
        server: viser.ViserServer,
        state: StudioState,
        notifier: Notifier,
        config: StudioConfig,
    ) -> None:
        self._server, self._state, self._notifier, self._config = server, state, notifier, config
        self.panel = RobotPanel(server.gui, self, config.max_upload_bytes)
        self.lighting = Lighting(server.scene)
        """Fast lighting unless the Display folder asks for the detailed one."""
        self.display = DisplayPanel(
            server.gui, self._on_display, self.frame_camera, self.lighting.set_detailed
        )
        self.view: RobotView | None = None
        self.stage: Signal[str] = Signal("load_stage")
        """Emitted with each stage of a load as it starts, as the Robot panel shows it."""
        self._roots = AlternatingRoot("/robot")
        self._admission = Admission()
        self.access = FileAccess.for_studio(
            Path.cwd(), (*config.allow, *config.package_roots), config.uploads_dir
        )
        """The folders *Open path* may load from (a path typed in a browser is untrusted)."""
        self.panel.path.hint = "A .urdf on the machine running the studio, inside " + ", ".join(
            self.access.describe()
        )
        state.on_robot.connect(self._on_robot)
        state.on_pose.connect(self._on_pose)
        state.on_display.connect(self._on_settings)

    # --- actions (RobotActions) ----------------------------------------------------------

    def load(self, source: str | Path, client: viser.ClientHandle | None = None) -> bool:
        """Load a robot; on failure say why and keep the current one. True on success.
        When other tabs are open, the tab that asks confirms first (the load replaces their
        robot and work too): False then, and the load happens on confirmation."""
        if self._needs_confirmation(client):
            assert client is not None
            self._confirm(client, str(source), lambda: self._load(source, client, sandbox=None))
            return False
        return self._load(source, client, sandbox=None)

    def _needs_confirmation(self, client: viser.ClientHandle | None) -> bool:
        if client is None or self._state.robot is None:
            return False
        return any(other != client.client_id for other in self._server.get_clients())

    def _confirm(self, client: viser.ClientHandle, what: str, load) -> None:
        """Ask the tab whether to replace every tab's robot and work."""
        others = len(self._server.get_clients()) - 1
        with client.gui.add_modal("Replace the robot for every tab?") as modal:
            client.gui.add_markdown(
                f"{others} other tab(s) use this studio. Loading **{Path(what).name}** replaces "
                "the robot there too and drops its motion, keyframes and torques."
            )
            replace = client.gui.add_button("Load it", color="red")
            cancel = client.gui.add_button("Cancel")

        @replace.on_click
        def _(_event: viser.GuiEvent) -> None:
            modal.close()
            load()

        @cancel.on_click
        def _(_event: viser.GuiEvent) -> None:
            modal.close()

    def load_upload(
        self, filename: str, content: bytes, client: viser.ClientHandle | None = None
    ) -> bool:
        """Store an uploaded .urdf/.zip in its own folder and load it from there."""
        self._say(
            f"Received **{Path(filename).name}** ({_size(len(content))}): unpacking and checking…"
        )
        try:
            urdf = store_upload(
                filename, content, self._config.uploads_dir, self._config.max_upload_bytes
            )
        except StudioError as error:
            self._fail("Upload refused", str(error), client)
            return False
        except (OSError, ValueError, RuntimeError, NotImplementedError, MemoryError) as error:
            log.exception("upload %s", filename)
            self._fail("Upload refused", f"{filename}: {type(error).__name__}: {error}", client)
            return False
        if self._needs_confirmation(client):
            assert client is not None
            self._confirm(client, filename, lambda: self._load(urdf, client, sandbox=urdf.parent))
            return False
        return self._load(urdf, client, sandbox=urdf.parent)

    def _load(
        self, source: str | Path, client: viser.ClientHandle | None, sandbox: Path | None
    ) -> bool:
        if not str(source).strip():
            self._fail("Nothing to open", "type the path of a .urdf file first", client)
            return False
        try:
            with self._admission.admit(client.client_id if client is not None else None):
                return self._load_admitted(source, client, sandbox)
        except Busy as busy:
            self._fail("Not now", str(busy), client)
            return False

    def _load_admitted(
        self, source: str | Path, client: viser.ClientHandle | None, sandbox: Path | None
    ) -> bool:
        options: dict = {
            "package_roots": self._config.package_roots,
            "feet": self._config.feet,
            "access": self.access,
        }
        if sandbox is not None:
            options = {**options, "sandbox": sandbox, "feet": None}
        name = Path(str(source)).name
        progress = self._notifier.progress("Loading", name, client)
        started_s = time.monotonic()
        current = ["starting"]

        def stage(what: str) -> None:
            current[0] = what
            elapsed = time.monotonic() - started_s
            self._say(f"⏳ Loading **{name}**: {what}… ({elapsed:.1f} s)", progress)

        try:
            robot = load_robot(source, **options, progress=stage)
            stage("checking the robot")
            report = robot_report(robot)
            stage("preparing the posing")
            prepare(robot)
            stage("building the scene")
        except StudioError as error:
            self._fail("Could not load the robot", str(error), client)
            return False
        except Exception as error:  # a third-party parser or mesh library failed: same answer
            log.exception("loading %s", source)
            first_line = (str(error).strip().splitlines() or [""])[0]
            self._fail(
                "Could not load the robot",
                f"{type(error).__name__} while {current[0]}: {first_line}",
                client,
            )
            return False
        finally:
            progress.done()
        with self._state.lock, self._server.atomic():
            self._state.set_robot(robot, report)
        problems = f", {len(report.problems)} problem(s) in the report" if report.problems else ""
        self._notifier.notify(
            "Robot loaded",
            f"{robot.name}: {robot.n_actuated} actuated joints, {robot.mass_kg:.2f} kg{problems}.",
            client,
            "yellow" if report.problems else "green",
        )
        if client is not None:
            for other in self._server.get_clients().values():
                if other.client_id != client.client_id:
                    self._notifier.notify(
                        "Robot replaced by another tab",
                        f"{robot.name} is now loaded.",
                        other,
                        "blue",
                    )
        return True

    def _say(self, text: str, progress: Progress | None = None) -> None:
        """Show the stage a load is in (Robot panel, loading notification)."""
        self.panel.show_status(text)
        if progress is not None:
            progress.say(text.replace("**", ""))
        self.stage.emit(text)

    def _fail(self, title: str, body: str, client: viser.ClientHandle | None) -> None:
        loaded = self._state.robot
        kept = " — the previous robot is still loaded." if loaded is not None else "."
        self.panel.show_status(f"⚠️ {body}{kept}")
        if loaded is not None:  # the dropdown shows what is loaded, not what was refused
            self.panel.show_builtin(loaded.name)
        self._notifier.error(title, f"{body}{kept}", client)

    # --- state changes --------------------------------------------------------------------

    def _on_robot(self, loaded: LoadedRobot) -> None:
        robot = loaded.robot
        if self.view is not None:
            self.view.remove()
        # A fresh root per robot: nodes re-added under a reused name can keep stale poses.
        self.view = RobotView(self._server, robot, root=self._roots.next())
        self.view.set_visible(**vars_of(self.display.flags()))
        self.panel.show_report(loaded.report)
        self.panel.show_builtin(robot.name)
        self.panel.show_status(f"**{robot.name}** — {robot.n_actuated} DOF, {robot.mass_kg:.2f} kg")
        self._frame(robot, robot.q_neutral, None)

    def _on_pose(self, pose: Pose) -> None:
        if self.view is not None:
            self.view.update(pose.q)

    def frame_camera(self, client: viser.ClientHandle | None = None) -> None:
        """Point a tab's camera (every tab's, and new tabs', without `client`) at the robot
        in its current pose."""
        with self._state.lock:
            robot, pose = self._state.robot, self._state.pose
        if robot is not None and pose is not None:
            self._frame(robot, pose.q, client)

    def _frame(self, robot: RobotModel, q: np.ndarray, client: viser.ClientHandle | None) -> None:
        lower, upper = robot.bounds_m(q, robot.model.createData())
        height = max(float(upper[2] - min(lower[2], 0.0)), 0.3)
        centre = 0.5 * (lower + upper)
        look_at = (float(centre[0]), float(centre[1]), 0.45 * height)
        position = (centre[0] + 0.95 * height, centre[1] + 0.7 * height, 0.7 * height)
        if client is None:
            self._server.initial_camera.position = position
            self._server.initial_camera.look_at = look_at
        for target in [client] if client is not None else self._server.get_clients().values():
            target.camera.position = position
            target.camera.look_at = look_at

    def _on_display(self, flags: DisplayFlags) -> None:
        with self._state.lock:
            if self.view is not None:
                self.view.set_visible(**vars_of(flags))
                self.view.update(self._state.q)
            self._state.set_display("panel", **dataclasses.asdict(flags))

    def _on_settings(self, display: Display) -> None:
        """An opened project's toggles: the Display panel and the robot's layers follow."""
        if display.origin != "project":
            return
        settings = display.settings
        flags = DisplayFlags(
            settings.visual, settings.collision, settings.frames, settings.com, settings.dark
        )
        self.display.show(flags)
        with self._state.lock:
            if self.view is not None:
                self.view.set_visible(**vars_of(flags))
                self.view.update(self._state.q)


def prepare(robot: RobotModel) -> None:
    """Everything the studio computes for a new robot before showing it, so that a robot that
    cannot be posed (degenerate soles, …) is refused before it replaces the current one."""
    Posing(robot).balance(robot.q_neutral)


def _size(n_bytes: int) -> str:
    return f"{n_bytes / 2**20:.1f} MB" if n_bytes >= 2**20 else f"{n_bytes / 2**10:.0f} kB"


def vars_of(flags: DisplayFlags) -> dict[str, bool]:
    return {
        "visual": flags.visual,
        "collision": flags.collision,
        "frames": flags.frames,
        "com": flags.com,
    }
