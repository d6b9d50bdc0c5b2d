"""The player: one named thread that moves the studio along its trajectory at display rate."""

from __future__ import annotations

import threading
import time
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from app.studio import Studio

DISPLAY_RATE_HZ = 60.0


class Player:
    def __init__(self, studio: Studio) -> None:
        self._studio = studio
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    @property
    def playing(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def play(self, from_time_s: float) -> None:
        self.pause()
        self._stop.clear()
        self._thread = threading.Thread(
            target=self._run, args=(from_time_s,), name="playback", daemon=True
        )
        self._thread.start()

    def pause(self) -> None:
        self._stop.set()
        thread = self._thread
        if thread is not None and thread is not threading.current_thread():
            thread.join(timeout=2.0)
        self._thread = None

    def _run(self, from_time_s: float) -> None:
        studio = self._studio
        start_wall, start_time = time.perf_counter(), from_time_s
        period = 1.0 / DISPLAY_RATE_HZ
        while not self._stop.is_set():
            trajectory = studio.trajectory
            if trajectory is None:
                return
            elapsed = (time.perf_counter() - start_wall) * studio.playback_panel.speed_factor
            now = start_time + elapsed
            if now > trajectory.duration:
                if not studio.playback_panel.loop.value:
                    studio.show_time(trajectory.duration, playing=False)
                    return
                start_wall, start_time, now = time.perf_counter(), 0.0, 0.0
            studio.show_time(now, playing=True)
            self._stop.wait(period)
