"""Projects in the studio: Save / Save as / Open (a path or an upload), the dirty marker,
restoring the last autosave, and undo / redo.

The work as a project keeps it (marks and the Project they make, from the state and the
sessions that implement `HoldsWork`) is app/studio/project_work.py; the paths typed to save and
open, app/studio/project_paths.py; the autosave thread, app/studio/project_autosave.py; undo and
redo, app/studio/project_undo.py. This module holds the flows: which file the work is, saving
it, and opening a project.

Opening is all or nothing: the file is read and checked, its robot loaded and prepared, every
value checked against that robot before anything in the studio changes; if installing still
fails (a bug), the work as it was is installed again. An autosave names the project the work
was (its name and file), so that a restored project keeps them; only unnamed work comes back as
"untitled (restored)".
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from datetime import datetime
from pathlib import Path

import viser

from app.config import StudioConfig
from app.core.atomic_write import write_binary_atomically
from app.core.errors import StudioError
from app.core.file_access import FileAccess
from app.core.posing.drag import Posing
from app.core.projects.autosave import AutosaveStore
from app.core.projects.codec import ProjectError
from app.core.projects.files import parse_project, read_project, write_project
from app.core.projects.project import Project, check_fits
from app.core.projects.robot_files import load_project_robot
from app.core.robot.model import RobotModel
from app.core.robot.report import RobotReport, robot_report
from app.studio.notifier import Notifier
from app.studio.project_autosave import Autosaver
from app.studio.project_paths import ProjectPaths, file_time, origin, saved_time
from app.studio.project_undo import HoldsKeyframes, HoldsServoParts, UndoSteps
from app.studio.project_work import HoldsWork, Marks, ProjectWork, contents, same
from app.studio.state import StudioState
from panels.project_panel import ProjectPanel

log = logging.getLogger(__name__)

UNTITLED = "untitled"
RESTORED = "untitled (restored)"
"""The name of restored work that had no project name."""

__all__ = ["HoldsKeyframes", "HoldsWork", "ProjectSession"]


class ProjectSession:
    """Owns the Project panel, the current project file, autosave and undo."""

    def __init__(
        self,
        server: viser.ViserServer,
        state: StudioState,
        notifier: Notifier,
        config: StudioConfig,
        parts: Sequence[HoldsWork],
        keyframes: HoldsKeyframes,
        dragging: Callable[[], bool] = lambda: False,
        servos: HoldsServoParts | None = None,
    ) -> None:
        """dragging: whether a tab holds a drag handle now (a drag is one undo step however
        slowly it goes: no step is taken before the handle is released)."""
        self._server, self._state, self._notifier, self._config = server, state, notifier, config
        self._work = ProjectWork(state, parts, config.package_roots)
        projects_dir = config.data_dir / "projects"
        store = AutosaveStore(config.data_dir / "autosave")
        self.paths = ProjectPaths(
            projects_dir,
            FileAccess.for_studio(
                Path.cwd(), (*config.allow, projects_dir, store.folder), config.uploads_dir
            ),
        )
        self.panel = ProjectPanel(server.gui, self, str(projects_dir))
        self.undo_steps = UndoSteps(
            server, state, notifier, self.panel, keyframes, dragging, self._work.marks, servos
        )
        self.autosave = Autosaver(
            store, state, self._work, self._looked, self._origin, (self.panel, notifier)
        )
        """The autosave thread and store (`autosave.now()`, `autosave.written`)."""
        self.path: Path | None = None
        self.name = UNTITLED
        self.saved_at = ""
        self.last_error = ""
        """Why the last save or open failed."""
        self.welcome = ""
        """"Restored your work from HH:MM", shown to every tab that connects, if restored."""
        self.skipped_autosaves: tuple[str, ...] = ()
        """Why each autosave newer than the one restored was skipped (it failed a check)."""
        server.on_client_connect(self._greet)

    # --- the work --------------------------------------------------------------------------

    def project(self, marks: Marks | None = None) -> Project:
        """The work (the current one without `marks`) as a Project."""
        return self._work.project(marks)

    @property
    def dirty(self) -> bool:
        return self._work.dirty

    # --- actions (ProjectActions) ----------------------------------------------------------

    def save(self, client: viser.ClientHandle | None = None) -> bool:
        if self.path is None:
            typed = str(self.panel.path.value).strip()
            if not typed:
                return self._fail("Nothing saved", "type a name or path, then Save as", client)
            return self.save_as(typed, client)
        return self._save_to(self.path, client)

    def save_as(self, path: str, client: viser.ClientHandle | None = None) -> bool:
        try:
            target = self.paths.to_save(path)
        except StudioError as error:
            return self._fail("Not saved", str(error), client)
        return self._save_to(target, client)

    def _save_to(self, path: Path, client: viser.ClientHandle | None) -> bool:
        self._state.flush_camera()  # the view as it is now, not as it was a second ago
        work = self._work
        marks = work.marks()
        try:
            project = work.project(marks)
            with work.lock:  # streamed entry by entry: no copy of the arrays in memory
                write_binary_atomically(
                    path, lambda file: write_project(file, project), ProjectError
                )
                work.saved = marks
        except StudioError as error:
            return self._fail("Not saved", str(error), client)
        self.path, self.name = path, path.stem
        self.saved_at = datetime.now().strftime("%H:%M:%S")
        self.welcome = ""
        self.panel.show_path(str(path))
        self._show_title(marks)
        notes = project.robot.notes
        self.panel.show_status(f"Saved to `{path}`" + "".join(f"  \n⚠️ {n}" for n in notes))
        self._notifier.notify("Project saved", str(path), client)
        return True

    def open(
        self, path: str | Path, client: viser.ClientHandle | None = None, trusted: bool = False
    ) -> bool:
        """Open a .bstudio file; `trusted` for a path given on the command line (not checked
        against the allowed folders, which guard paths typed in a browser)."""
        if not str(path).strip():
            return self._fail("Nothing to open", "type the path of a .bstudio file", client)
        if "\0" in str(path):  # Path.exists would raise ValueError on it
            return self._fail("Project not opened", "a path cannot hold a NUL character", client)
        try:
            resolved = self.paths.to_open(str(path), trusted)
            project = read_project(resolved)
        except StudioError as error:
            return self._fail("Project not opened", str(error), client)
        return self.install(project, resolved.stem, resolved, client)

    def open_upload(
        self, filename: str, content: bytes, client: viser.ClientHandle | None = None
    ) -> bool:
        try:
            project = parse_project(content, filename)
        except StudioError as error:
            return self._fail("Project not opened", str(error), client)
        return self.install(project, Path(filename).stem or "uploaded", None, client)

    def undo(self, client: viser.ClientHandle | None = None) -> bool:
        """Go back one step of pose and keyframe edits, saying which; False if there is none."""
        return self.undo_steps.undo(client)

    def redo(self, client: viser.ClientHandle | None = None) -> bool:
        return self.undo_steps.redo(client)

    # --- installing a project ------------------------------------------------------------

    def install(
        self,
        project: Project,
        name: str,
        path: Path | None,
        client: viser.ClientHandle | None = None,
        saved: bool = True,
        announce: bool = True,
    ) -> bool:
        """Show `project` in the studio, all or nothing; False (work untouched) on failure.
        `saved`: the project is a saved file (not dirty once open). `announce`: a project
        that does not fit is told to the tabs (else only `last_error` says why)."""
        try:
            robot = load_project_robot(
                project.robot, self._config.uploads_dir, self._config.package_roots
            )
            report = robot_report(robot)
            Posing(robot).balance(robot.q_neutral)  # a robot that cannot be posed is refused
            check_fits(project, robot)  # and every value, as a load from the panels checks it
        except StudioError as error:
            if not announce:
                self.last_error = str(error)
                return False
            return self._fail("Project not opened", str(error), client)
        except Exception as error:  # a third-party parser failed on the robot: same answer
            log.exception("opening project %s", name)
            return self._fail("Project not opened", f"{type(error).__name__}: {error}", client)
        previous = self._state.loaded
        try:
            before = self.project() if previous is not None else None
        except StudioError:  # the current robot's files cannot be packed: no way back, go on
            before = None
        try:
            self._install(robot, report, project)
        except Exception as error:  # a bug: put the work back as it was
            log.exception("installing project %s", name)
            if previous is not None and before is not None:
                self._install(previous.robot, previous.report, before)
            return self._fail("Project not opened", f"{type(error).__name__}: {error}", client)
        marks = self._work.marks()
        with self._work.lock:
            self._work.saved = marks if saved else None
        self.path, self.name = path, name
        self.saved_at = saved_time(project.saved_at) if saved else ""
        self.welcome = ""
        self.panel.show_path(str(path) if path is not None else "")
        self._show_title(marks)
        notes = "".join(f"  \n⚠️ {n}" for n in project.robot.notes)
        self.panel.show_status(f"Opened **{name}** ({robot.name})" + notes)
        self._notifier.notify("Project opened", f"{name}: {robot.name}", client)
        return True

    def _install(self, robot: RobotModel, report: RobotReport, project: Project) -> None:
        state = self._state
        with state.lock, self._server.atomic():
            state.set_robot(robot, report)
            if project.motion is not None:
                state.set_motion(project.motion, project.motion_summary, robot)
            for part in self._work.parts:
                part.restore(project)
            state.restore_display(project.display)
            if project.motion is not None:
                state.set_time(project.time_s)
            state.set_pose(project.q.copy(), project.stance, "load", robot)

    # --- autosave ----------------------------------------------------------------------------

    def restore_autosave(self) -> bool:
        """Install the newest autosave that opens and passes every check; say so to every
        tab, with a note for each newer one skipped. False if none."""
        skipped: list[str] = []
        self.skipped_autosaves = ()
        for path in reversed(self.autosave.store.saves()):
            try:
                project = read_project(path)
            except StudioError as error:
                log.warning("autosave %s not restored: %s", path.name, error)
                skipped.append(f"`{path.name}` skipped: {error}")
                continue
            name, where = origin(project)
            if not self.install(project, name or RESTORED, where, saved=False, announce=False):
                log.warning("autosave %s not restored: %s", path.name, self.last_error)
                skipped.append(f"`{path.name}` skipped: {self.last_error}")
                continue
            self.skipped_autosaves = tuple(skipped)
            if where is not None:  # when its file was last saved, if it still is there
                self.saved_at = file_time(where)
                self._show_title(self._work.marks())
            when = saved_time(project.saved_at, "%H:%M")
            work = f"{name} ({contents(project)})" if name else contents(project)
            self.welcome = f"Restored your work from {when}: {work}"
            notes = "".join(f"  \n⚠️ {note}" for note in skipped)
            self.panel.show_status(f"{self.welcome} (autosave `{path.name}`){notes}")
            self._notifier.notify("Welcome back", self.welcome)
            return True
        self.skipped_autosaves = tuple(skipped)
        if skipped:
            notes = "  \n".join(f"⚠️ {note}" for note in skipped)
            self.panel.show_status(f"No autosave restored; the studio starts fresh.  \n{notes}")
        return False

    def _greet(self, client: viser.ClientHandle) -> None:
        if self.welcome:
            client.add_notification("Welcome back", self.welcome, auto_close_seconds=15.0)

    def start_autosave(self, now: bool = False) -> None:
        """Watch the work from now on; `now`: autosave it at once (a project opened at start
        is the work now), else take it as already autosaved (a fresh start is no work)."""
        work = self._work
        marks = work.marks()
        self.undo_steps.record(marks)
        with work.lock:
            if work.saved is None and self.path is None and not self.welcome:
                work.saved = marks  # a fresh start: nothing to save yet
        self._show_title(marks)
        self.autosave.start(None if now else marks)

    def _looked(self, marks: Marks) -> None:
        """The autosave thread looked at the work: the title's marker, an undo step."""
        self._show_title(marks)
        self.undo_steps.record(marks)

    def _origin(self) -> tuple[str, str]:
        """What an autosave of the work names: the project's name and file."""
        name = "" if self.name in (UNTITLED, RESTORED) else self.name
        return name, str(self.path) if self.path is not None else ""

    def stop(self) -> None:
        self.autosave.stop()

    # --- display ---------------------------------------------------------------------------

    def _show_title(self, marks: Marks) -> None:
        self.panel.show_title(self.name, not same(self._work.saved, marks), self.saved_at)

    def _fail(self, title: str, body: str, client: viser.ClientHandle | None) -> bool:
        self.last_error = body
        self.panel.show_status(f"⚠️ {body} — your current work is unchanged.")
        self._notifier.error(title, f"{body} — your current work is unchanged.", client)
        return False
