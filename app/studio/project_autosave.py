"""Autosave: the work written to the data folder's autosave/ when it changed, on a named thread.

State signals and a one-second poll wake the thread ("autosave") which, once the work has been
still for QUIET_S (or MAX_DELAY_S after the first change), compares the work with the last
autosave (by identity: every edit replaces the value it edits) and writes a new one when it
changed. Drags only set an event: the snapshot (references, no copies), the serialisation and
the write all run on the autosave thread, never on viser's callback threads (a profile of 160
paced drags finds nothing of autosave on the drag's thread but that `Event.set`;
`biped-studio bench --only projects` compares drags with autosave on and held). A failing write
keeps the earlier autosaves and is reported once until a write succeeds again. An autosave
names the project the work was (its name and file), so that a restored project keeps them.
"""

from __future__ import annotations

import dataclasses
import logging
import threading
import time
from collections.abc import Callable
from pathlib import Path

from app.core.errors import StudioError
from app.core.projects.autosave import AutosaveStore
from app.core.projects.files import write_project
from app.studio.notifier import Notifier
from app.studio.project_work import Marks, ProjectWork, same
from app.studio.signals import Signal
from app.studio.state import StudioState
from panels.project_panel import ProjectPanel

log = logging.getLogger(__name__)

POLL_S = 1.0
"""Longest time between two looks for changes the state does not announce (slider edits)."""
QUIET_S = 0.3
"""An autosave is written once the work has not changed for this long (a drag pauses)…"""
MAX_DELAY_S = 5.0
"""… or this long after the first unsaved change, whatever goes on (a long drag, playback)."""

Origin = Callable[[], tuple[str, str]]
"""The name and file of the project the work is ("" for each it has not)."""


class Autosaver:
    """The "autosave" thread and the autosave store (see the module's docstring)."""

    def __init__(
        self,
        store: AutosaveStore,
        state: StudioState,
        work: ProjectWork,
        looked: Callable[[Marks], None],
        origin: Origin,
        said: tuple[ProjectPanel, Notifier],
    ) -> None:
        """looked: called with the work at every look (the title's dirty marker, undo steps)."""
        self.store = store
        self._state, self._work = state, work
        self._looked, self._origin = looked, origin
        self._panel, self._notifier = said
        self.paused = False
        """Autosave held (the bench measures drags with and without it)."""
        self.written: Signal[Path] = Signal("autosaved")
        self.failed: Signal[str] = Signal("autosave_failed")
        self._last: Marks | None = None
        """The work as last autosaved (None: not yet)."""
        self._failing = False
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

    def start(self, autosaved: Marks | None) -> None:
        """Watch the work from now on, taking `autosaved` as already autosaved (None: write
        the work now)."""
        with self._work.lock:
            self._last = autosaved
        self._thread = threading.Thread(target=self._run, name="autosave", daemon=True)
        self._thread.start()
        if autosaved is None:
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
                self.now()
            except Exception:  # a bug must not end autosaving for the rest of the session
                log.exception("autosave")

    def now(self) -> Path | None:
        """Write an autosave if the work changed since the last one; its path, else None."""
        if self.paused:
            return None
        work = self._work
        marks = work.marks()
        if not same(self._last, marks):  # something changed: the camera goes along
            self._state.flush_camera()
            marks = work.marks()
        self._looked(marks)
        if marks["loaded"] is None or same(self._last, marks):
            return None
        try:
            name, path = self._origin()
            project = dataclasses.replace(work.project(marks), autosave_of=name, autosave_path=path)
            with work.lock:
                written = self.store.write(lambda file: write_project(file, project))
                self._last = marks
        except StudioError as error:
            if not self._failing:
                self._failing = True
                message = f"{error}. Earlier autosaves are kept; your work is still open here."
                self._notifier.error("Autosave failed", message)
                self._panel.show_status(f"⚠️ Autosave failed: {message}")
                self.failed.emit(str(error))
            return None
        if self._failing:
            self._failing = False
            self._panel.show_status("Autosave works again.")
        self.written.emit(written)
        return written

    def stop(self) -> None:
        self._stop.set()
        self._wake.set()
        if self._thread is not None:
            self._thread.join()
