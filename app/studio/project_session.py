"""Projects in the studio: Save / Save as / Open (a path or an upload), the dirty marker, and
autosave.

The work lives in the shared state (robot, pose, motion, playback time) and in the sessions
that hold user state (keyframes, torques and coefficients, gaits). Each of those sessions
implements `HoldsWork` (`snapshot()` / `restore()`); server.py hands them to this session,
which never imports them.

Opening is all or nothing: the file is read and checked, its robot loaded and prepared, every
value checked against that robot before anything in the studio changes; if installing still
fails (a bug), the work as it was is installed again.

Autosave: state signals and a one-second poll wake a named thread ("autosave") which, once
the work has been still for QUIET_S (or MAX_DELAY_S after the first change), compares the
work with the last autosave (by identity: every edit replaces the value it edits) and writes
a new one when it changed. Drags only set an event: the snapshot (references, no copies),
the serialisation and the write all run on the autosave thread, never on viser's callback
threads (a profile of 160 paced drags finds nothing of autosave on the drag's thread but
that `Event.set`; `biped-studio bench --only projects` compares drags with autosave on and
held). A failing write keeps the earlier autosaves and is
reported once until a write succeeds again. An autosave names the project the work was (its
name and file), so that a restored project keeps them; only unnamed work comes back as
"untitled (restored)".
"""

from __future__ import annotations

import dataclasses
import logging
import threading
import time
from collections.abc import Callable, Sequence
from datetime import datetime
from pathlib import Path
from typing import Any, Protocol

import viser

from app.config import StudioConfig
from app.core.atomic_write import write_binary_atomically
from app.core.collocation.settings import GaitSettings
from app.core.errors import StudioError
from app.core.file_access import FileAccess
from app.core.motions.keyframes import Keyframe
from app.core.posing.drag import Posing
from app.core.projects.autosave import AutosaveStore
from app.core.projects.codec import ProjectError
from app.core.projects.display import ALL_JOINTS, DisplaySettings, plot_choices, same_display
from app.core.projects.files import SUFFIX, parse_project, read_project, write_project
from app.core.projects.project import Project, RobotSource, check_fits
from app.core.projects.robot_files import load_project_robot, robot_source
from app.core.robot.model import RobotModel
from app.core.robot.report import RobotReport, robot_report
from app.studio.notifier import Notifier
from app.studio.signals import Signal
from app.studio.state import LoadedRobot, Pose, StudioState
from app.studio.undo import Move, Step, UndoHistory
from panels.project_panel import ProjectPanel

log = logging.getLogger(__name__)

POLL_S = 1.0
"""Longest time between two looks for changes the state does not announce (slider edits)."""
QUIET_S = 0.3
"""An autosave is written once the work has not changed for this long (a drag pauses)…"""
MAX_DELAY_S = 5.0
"""… or this long after the first unsaved change, whatever goes on (a long drag, playback)."""
UNTITLED = "untitled"
RESTORED = "untitled (restored)"
"""The name of restored work that had no project name."""


class HoldsKeyframes(Protocol):
    """The session holding the keyframe list (undo and redo put one back)."""

    def set_keyframes(self, keyframes: tuple[Keyframe, ...]) -> None: ...


class HoldsServoParts(Protocol):
    """The session holding the servo parts (undo and redo put a choice back)."""

    def restore_parts(self, choice: Any, coefficients: tuple[Any, Any]) -> None: ...


class HoldsWork(Protocol):
    """A session holding user state that a project keeps."""

    def snapshot(self) -> dict[str, Any]:
        """Its part of a Project: field name → current value (no copies: values are replaced,
        never changed in place, on every edit)."""
        ...

    def restore(self, project: Project) -> None:
        """Show `project`'s part; called after the project's robot and motion are installed."""
        ...


Marks = dict[str, Any]


class ProjectSession:
    """Owns the Project panel, the current project file and the autosave thread."""

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
        self._dragging = dragging
        self._parts = tuple(parts)
        self._keyframes = keyframes
        self._servos = servos
        self.history = UndoHistory()
        self._undo_lock = threading.Lock()
        """Taking a step and going to one never interleave."""
        """Pose and keyframe edits, one step per still moment (app.studio.undo)."""
        self.projects_dir = config.data_dir / "projects"
        self.autosaves = AutosaveStore(config.data_dir / "autosave")
        self.access = FileAccess.for_studio(
            Path.cwd(),
            (*config.allow, self.projects_dir, self.autosaves.folder),
            config.uploads_dir,
        )
        self.panel = ProjectPanel(server.gui, self, str(self.projects_dir))
        self.path: Path | None = None
        self.name = UNTITLED
        self.saved_at = ""
        self.last_error = ""
        """Why the last save or open failed."""
        self.welcome = ""
        """"Restored your work from HH:MM", shown to every tab that connects, if restored."""
        self.skipped_autosaves: tuple[str, ...] = ()
        """Why each autosave newer than the one restored was skipped (it failed a check)."""
        self.autosaved: Signal[Path] = Signal("autosaved")
        self.autosave_failed: Signal[str] = Signal("autosave_failed")
        self._lock = threading.Lock()
        """Guards the marks below and file writes (save and autosave may overlap)."""
        self._saved: Marks | None = None
        self._autosaved: Marks | None = None
        self._failing = False
        self._sources: tuple[RobotModel, RobotSource] | None = None
        self.paused = False
        """Autosave held (the bench measures drags with and without it)."""
        self._wake = threading.Event()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        for signal in (
            state.on_robot,
            state.on_pose,
            state.on_motion,
            state.on_time,
            state.on_display,
        ):
            signal.connect(lambda _value: self._wake.set())
        server.on_client_connect(self._greet)

    # --- the work as marks and as a Project ----------------------------------------------

    def marks(self) -> Marks:
        """The current work, by reference: compared with `_same`, turned into a Project."""
        with self._state.lock:
            marks: Marks = {
                "loaded": self._state.loaded,
                "pose": self._state.pose,
                "motion": self._state.motion,
                "time_s": self._state.time_s,
                "display": self._state.display.settings,
            }
        for part in self._parts:
            marks.update(part.snapshot())
        return marks

    def project(self, marks: Marks | None = None) -> Project:
        """The work (the current one without `marks`) as a Project."""
        marks = self.marks() if marks is None else marks
        loaded, pose, motion = marks["loaded"], marks["pose"], marks["motion"]
        if loaded is None or pose is None:
            raise ProjectError("no robot is loaded: nothing to save")
        fields = {k: v for k, v in marks.items() if k not in ("loaded", "pose", "motion")}
        display: DisplaySettings = fields["display"]
        if display.plot_joints not in plot_choices(loaded.robot.joint_names):
            fields["display"] = dataclasses.replace(display, plot_joints=ALL_JOINTS)
        return Project(
            robot=self._source(loaded.robot),
            q=pose.q,
            stance=pose.stance,
            motion=motion.trajectory if motion is not None else None,
            motion_summary=motion.summary if motion is not None else "",
            **fields,
        )

    def _source(self, robot: RobotModel) -> RobotSource:
        cached = self._sources
        if cached is not None and cached[0] is robot:
            return cached[1]
        source = robot_source(robot, self._config.package_roots)
        self._sources = (robot, source)
        return source

    @property
    def dirty(self) -> bool:
        return not _same(self._saved, self.marks())

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
            target = self._target(path)
        except StudioError as error:
            return self._fail("Not saved", str(error), client)
        return self._save_to(target, client)

    def _target(self, typed: str) -> Path:
        if not typed:
            raise ProjectError("type a name or a path for the project")
        path = Path(typed).expanduser()
        if path.suffix.lower() != SUFFIX:
            path = path.with_name(path.name + SUFFIX)
        if len(path.parts) == 1:  # a bare name: the data folder's projects/
            self.projects_dir.mkdir(parents=True, exist_ok=True)
            path = self.projects_dir / path
        return self.access.check(path)

    def _save_to(self, path: Path, client: viser.ClientHandle | None) -> bool:
        self._state.flush_camera()  # the view as it is now, not as it was a second ago
        marks = self.marks()
        try:
            project = self.project(marks)
            with self._lock:  # streamed entry by entry: no copy of the arrays in memory
                write_binary_atomically(
                    path, lambda file: write_project(file, project), ProjectError
                )
                self._saved = marks
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
        typed = Path(str(path).strip()).expanduser()
        if len(typed.parts) == 1 and not typed.exists():
            typed = self.projects_dir / typed
            if typed.suffix.lower() != SUFFIX:
                typed = typed.with_name(typed.name + SUFFIX)
        try:
            resolved = typed.resolve() if trusted else self.access.check(typed)
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
        marks = self.marks()
        with self._lock:
            self._saved = marks if saved else None
        self.path, self.name = path, name
        self.saved_at = _saved_time(project.saved_at) if saved else ""
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
            for part in self._parts:
                part.restore(project)
            state.restore_display(project.display)
            if project.motion is not None:
                state.set_time(project.time_s)
            state.set_pose(project.q.copy(), project.stance, "load", robot)

    def restore_autosave(self) -> bool:
        """Install the newest autosave that opens and passes every check; say so to every
        tab, with a note for each newer one skipped. False if none."""
        skipped: list[str] = []
        self.skipped_autosaves = ()
        for path in reversed(self.autosaves.saves()):
            try:
                project = read_project(path)
            except StudioError as error:
                log.warning("autosave %s not restored: %s", path.name, error)
                skipped.append(f"`{path.name}` skipped: {error}")
                continue
            name, origin = _origin(project)
            if not self.install(project, name or RESTORED, origin, saved=False, announce=False):
                log.warning("autosave %s not restored: %s", path.name, self.last_error)
                skipped.append(f"`{path.name}` skipped: {self.last_error}")
                continue
            self.skipped_autosaves = tuple(skipped)
            if origin is not None:  # when its file was last saved, if it still is there
                self.saved_at = _file_time(origin)
                self._show_title(self.marks())
            when = _saved_time(project.saved_at, "%H:%M")
            contents = _contents(project)
            work = f"{name} ({contents})" if name else contents
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

    # --- autosave --------------------------------------------------------------------------

    def start_autosave(self, now: bool = False) -> None:
        """Watch the work from now on; `now`: autosave it at once (a project opened at start
        is the work now), else take it as already autosaved (a fresh start is no work)."""
        marks = self.marks()
        self._record(marks)
        with self._lock:
            self._autosaved = None if now else marks
            if self._saved is None and self.path is None and not self.welcome:
                self._saved = marks  # a fresh start: nothing to save yet
        self._show_title(marks)
        self._thread = threading.Thread(target=self._run, name="autosave", daemon=True)
        self._thread.start()
        if now:
            self._wake.set()

    def _run(self) -> None:
        while not self._stop.is_set():
            self._wake.wait(POLL_S)
            first = time.monotonic()
            while True:  # wait for a quiet moment: a drag under way is never interrupted
                self._wake.clear()
                if self._stop.wait(QUIET_S):
                    return
                if not self._wake.is_set() or time.monotonic() - first >= MAX_DELAY_S:
                    break
            try:
                self.autosave_now()
            except Exception:  # a bug must not end autosaving for the rest of the session
                log.exception("autosave")

    def autosave_now(self) -> Path | None:
        """Write an autosave if the work changed since the last one; its path, else None."""
        if self.paused:
            return None
        marks = self.marks()
        if not _same(self._autosaved, marks):  # something changed: the camera goes along
            self._state.flush_camera()
            marks = self.marks()
        self._show_title(marks)
        self._record(marks)
        if marks["loaded"] is None or _same(self._autosaved, marks):
            return None
        try:
            work = dataclasses.replace(
                self.project(marks),
                autosave_of="" if self.name in (UNTITLED, RESTORED) else self.name,
                autosave_path=str(self.path) if self.path is not None else "",
            )
            with self._lock:
                path = self.autosaves.write(lambda file: write_project(file, work))
                self._autosaved = marks
        except StudioError as error:
            if not self._failing:
                self._failing = True
                message = f"{error}. Earlier autosaves are kept; your work is still open here."
                self._notifier.error("Autosave failed", message)
                self.panel.show_status(f"⚠️ Autosave failed: {message}")
                self.autosave_failed.emit(str(error))
            return None
        if self._failing:
            self._failing = False
            self.panel.show_status("Autosave works again.")
        self.autosaved.emit(path)
        return path

    # --- undo / redo (ProjectActions) -----------------------------------------------------

    def _record(self, marks: Marks) -> None:
        loaded: LoadedRobot | None = marks["loaded"]
        pose: Pose | None = marks["pose"]
        if loaded is None or pose is None or self._dragging():
            return
        with self._undo_lock:
            if self._state.pose is not pose:
                return  # it changed meanwhile (an undo): the next look takes it
            taken = self.history.record(_step(loaded, pose, marks))
        if taken:
            self.panel.show_undo(self.history.can_undo, self.history.can_redo)

    def undo(self, client: viser.ClientHandle | None = None) -> bool:
        """Go back one step of pose and keyframe edits, saying which; False if there is none."""
        said = ("Undid", "Redo puts it back.", "Nothing to undo")
        return self._go(self.history.undo(), said, client)

    def redo(self, client: viser.ClientHandle | None = None) -> bool:
        said = ("Redid", "Undo takes it back again.", "Nothing to redo")
        return self._go(self.history.redo(), said, client)

    def _go(
        self, move: Move | None, said: tuple[str, str, str], client: viser.ClientHandle | None
    ) -> bool:
        """Install `move`'s step; say "Undid: <edit>" (or that there was nothing) in the
        panel's status and to the tab that asked."""
        done, hint, nothing = said
        state = self._state
        applied = False
        if move is not None:
            step = move.step
            with self._undo_lock, state.lock, self._server.atomic():
                if state.loaded is step.loaded:
                    self._keyframes.set_keyframes(step.keyframes)
                    if self._servos is not None and step.servo_parts is not state.work.parts:
                        self._servos.restore_parts(step.servo_parts, step.coefficients)
                    state.set_pose(
                        step.pose.q.copy(), step.pose.stance, "button", step.loaded.robot
                    )
                    assert state.loaded is not None and state.pose is not None
                    self.history.replace_current(_step(state.loaded, state.pose, self.marks()))
                    applied = True
        self.panel.show_undo(self.history.can_undo, self.history.can_redo)
        if move is None or not applied:
            self.panel.show_status(nothing)
            self._notifier.notify(nothing, "", client, "yellow")
        else:
            self.panel.show_status(f"{done}: {move.edit}")
            self._notifier.notify(f"{done}: {move.edit}", hint, client, "blue")
        return applied

    def stop(self) -> None:
        self._stop.set()
        self._wake.set()
        if self._thread is not None:
            self._thread.join()

    # --- display ---------------------------------------------------------------------------

    def _show_title(self, marks: Marks) -> None:
        self.panel.show_title(self.name, not _same(self._saved, marks), self.saved_at)

    def _fail(self, title: str, body: str, client: viser.ClientHandle | None) -> bool:
        self.last_error = body
        self.panel.show_status(f"⚠️ {body} — your current work is unchanged.")
        self._notifier.error(title, f"{body} — your current work is unchanged.", client)
        return False


def _step(loaded: LoadedRobot, pose: Pose, marks: Marks) -> Step:
    """The undo step of the work in `marks`: pose, keyframes, servo parts (and coefficients)."""
    return Step(
        loaded,
        pose,
        tuple(marks.get("keyframes", ())),
        servo_parts=marks.get("servo_parts"),
        coefficients=(marks.get("compensation"), marks.get("servo")),
    )


def _same(a: Marks | None, b: Marks) -> bool:
    """Whether two marks hold the same work (the same objects, or equal plain values)."""
    if a is None or a.keys() != b.keys():
        return False
    return all(_same_value(a[key], b[key]) for key in a)


def _same_value(x: object, y: object) -> bool:
    if x is y:
        return True
    if isinstance(x, tuple) and isinstance(y, tuple):
        return len(x) == len(y) and all(_same_value(i, j) for i, j in zip(x, y, strict=True))
    if isinstance(x, DisplaySettings) and isinstance(y, DisplaySettings):
        return same_display(x, y)  # a tab's echo of a restored camera is the same view
    if isinstance(x, float | int | str | bool | GaitSettings):
        return type(x) is type(y) and x == y
    return False


def _origin(project: Project) -> tuple[str, Path | None]:
    """The name and file of the project an autosave is of ("", None for untitled work); a
    path that is not an absolute .bstudio path (a damaged or edited autosave) is dropped."""
    name = project.autosave_of.strip()
    if len(name) > 200 or not name.isprintable():
        name = ""
    typed = project.autosave_path
    path = Path(typed) if typed and "\x00" not in typed else None
    if path is not None and (not path.is_absolute() or path.suffix.lower() != SUFFIX):
        path = None
    if path is not None and not name:
        name = path.stem
    return name, path


def _contents(project: Project) -> str:
    """What a project holds, in a few words: robot, motion, keyframes, results."""
    parts = [project.robot.builtin or project.robot.name]
    if project.motion is not None:
        parts.append(f"motion {project.motion.name} at {project.time_s:.2f} s")
    if project.keyframes:
        parts.append(f"{len(project.keyframes)} keyframe(s)")
    parts += [
        what
        for what, present in (
            ("torques", project.feedforward is not None),
            ("gait", project.gait_symmetric is not None or project.gait_baseline is not None),
            ("simulation", bool(project.simulation)),
        )
        if present
    ]
    return ", ".join(parts)


def _file_time(path: Path) -> str:
    """The local clock time `path` was last written ("" when it cannot be read)."""
    try:
        return datetime.fromtimestamp(path.stat().st_mtime).strftime("%H:%M:%S")
    except OSError:
        return ""


def _saved_time(iso: str, fmt: str = "%H:%M:%S") -> str:
    """The local clock time of an ISO 8601 UTC stamp ("" when there is none)."""
    try:
        return datetime.fromisoformat(iso).astimezone().strftime(fmt)
    except ValueError:
        return ""
