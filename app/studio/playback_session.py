"""Playback in the studio: the timeline, play/pause, speed, loop, the traces of the current
motion, a camera that follows the robot, and the keys (Space, J / L). The player is one named
thread that moves the state's time at display rate; the pose of each sample is set here, and
every other feature follows the time through the state."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

import viser

from app.core.motions.paths import task_space_paths
from app.studio.camera_follow import CameraFollower
from app.studio.state import Display, Motion, StudioState
from app.views.roots import AlternatingRoot
from app.views.traces_view import TracesView
from panels.playback_panel import PlaybackPanel

DISPLAY_RATE_HZ = 60.0
IDLE_PER_BUSY = 1.0
"""The player waits at least as long as its last frame took (the pose, the ghosts, the plots'
cursor, the messages to every tab): ~11 ms of CPU per frame on servo_biped with ghosts, two
thirds of a core at 60 Hz, which a browser drawing in software on the same 2-core machine
needs more."""


class PlaybackSession:
    """Owns the Playback panel, the player thread and the traces overlay."""

    def __init__(self, server: viser.ViserServer, state: StudioState) -> None:
        self._server, self._state = server, state
        self.panel = PlaybackPanel(server.gui, self)
        self.player = Player(self._advance)
        self.traces: TracesView | None = None
        self.camera = CameraFollower(server)
        """Keeps the cameras on the pelvis while "Follow robot" is ticked."""
        self._roots = AlternatingRoot("/traces")
        state.on_motion.connect(self._on_motion)
        state.on_time.connect(self._on_time)
        state.on_play.connect(lambda _none: self.play())
        state.on_display.connect(self._on_display)

    # --- state changes ----------------------------------------------------------------------

    def _on_motion(self, motion: Motion | None) -> None:
        self.player.pause()
        if self.traces is not None:
            self.traces.remove()
            self.traces = None
        if motion is None:
            self.panel.show_none()
            return
        robot = self._state.robot
        assert robot is not None
        self.traces = TracesView(
            self._server,
            task_space_paths(robot, motion.trajectory),
            root=self._roots.next(),
        )
        self.traces.set_visible(self.panel.traces.value)
        self.panel.show_trajectory(motion.trajectory, motion.summary)

    def _on_time(self, time_s: float) -> None:
        state = self._state
        trajectory, robot = state.trajectory, state.robot
        if trajectory is None or robot is None:
            return
        k = trajectory.index_at(time_s)
        left, right = trajectory.contacts[k]
        stance = "both" if left == right else ("left" if left else "right")
        origin = "playback" if self.player.playing else "timeline"
        state.set_pose(trajectory.q[k], stance, origin, robot)  # type: ignore[arg-type]
        if self.panel.follow.value:
            self.camera.follow(trajectory.q[k][:3])  # the floating base: the pelvis
        self.panel.show_time(time_s)
        self.panel.show_playing(self.player.playing)

    def _on_display(self, display: Display) -> None:
        """An opened project's playback options: the panel, traces and camera follow them."""
        if display.origin != "project":
            return
        settings = display.settings
        self.panel.show_options(settings.traces, settings.follow, settings.loop, settings.speed)
        self._apply_traces(settings.traces)
        self._apply_follow(settings.follow)

    # --- actions (PlaybackActions) -------------------------------------------------------------

    def seek(self, time_s: float) -> None:
        self.player.pause()
        with self._state.lock, self._server.atomic():
            self._state.set_time(float(time_s))

    def toggle_play(self) -> None:
        if self.player.playing:
            self.player.pause()
            self.panel.show_playing(False)
            self.seek(self.panel.time.value)
            return
        trajectory = self._state.trajectory
        if trajectory is not None:
            start = float(self.panel.time.value)
            self.player.play(0.0 if start >= trajectory.duration else start)
            self.panel.show_playing(True)

    def step(self, frames: int) -> None:
        """Pause and show the sample `frames` samples after (before, if negative) the shown one."""
        with self._state.lock:
            trajectory = self._state.trajectory
            if trajectory is None:
                return
            k = trajectory.index_at(self._state.time_s) + int(frames)
            time_s = float(trajectory.t[min(max(k, 0), trajectory.n_samples - 1)])
        self.seek(time_s)

    def set_follow(self, follow: bool) -> None:
        """Follow the robot with the cameras from now on (from where it stands), or stop."""
        self._state.set_display("panel", follow=bool(follow))
        self._apply_follow(follow)

    def set_speed(self, speed: float) -> None:
        self._state.set_display("panel", speed=float(speed))

    def set_loop(self, loop: bool) -> None:
        self._state.set_display("panel", loop=bool(loop))

    def _apply_follow(self, follow: bool) -> None:
        if not follow:
            self.camera.stop()
            return
        with self._state.lock:
            q = self._state.q
        if len(q) >= 3:
            self.camera.follow(q[:3])

    def play(self) -> None:
        """Play the current motion from its start."""
        if self._state.trajectory is not None:
            self.player.play(0.0)
            self.panel.show_playing(True)

    def set_traces_visible(self, visible: bool) -> None:
        self._state.set_display("panel", traces=bool(visible))
        self._apply_traces(visible)

    def _apply_traces(self, visible: bool) -> None:
        with self._state.lock:
            if self.traces is not None:
                self.traces.set_visible(bool(visible))

    # --- the player's tick ----------------------------------------------------------------------

    def _advance(self, elapsed_s: float, start_s: float, stop: threading.Event) -> bool | None:
        """Show the motion at start + elapsed·speed. None to stop (the end, without loop),
        True to restart the clock from 0 (loop), False to go on."""
        with self._state.lock, self._server.atomic():
            trajectory = self._state.trajectory
            if trajectory is None or stop.is_set():
                return None
            now = start_s + elapsed_s * self.panel.speed_factor
            if now <= trajectory.duration:
                self._state.set_time(now)
                return False
            if self.panel.loop.value:
                self._state.set_time(0.0)
                return True
            stop.set()
            self._state.set_time(trajectory.duration)
            return None

    def stop(self) -> None:
        self.player.pause()
        self.camera.stop()


class Player:
    """One named thread, "playback", calling `tick(elapsed_s, start_s, stop)` at display rate
    (or slower: it rests at least as long as a tick took) until it returns None or `pause()`
    sets `stop`. `pause` never waits for the thread (it may
    be called from a state signal while the thread waits for the state's lock); `tick` checks
    `stop` under that lock, so no frame is shown after a pause."""

    def __init__(self, tick: Callable[[float, float, threading.Event], bool | None]) -> None:
        self._tick = tick
        self._stop = threading.Event()
        self._stop.set()

    @property
    def playing(self) -> bool:
        return not self._stop.is_set()

    def play(self, from_time_s: float) -> None:
        self.pause()
        stop = self._stop = threading.Event()
        threading.Thread(
            target=self._run, args=(from_time_s, stop), name="playback", daemon=True
        ).start()

    def pause(self) -> None:
        self._stop.set()

    def _run(self, from_time_s: float, stop: threading.Event) -> None:
        start_wall, start_time = time.perf_counter(), from_time_s
        period = 1.0 / DISPLAY_RATE_HZ
        while not stop.is_set():
            tick_started = time.perf_counter()
            restart = self._tick(tick_started - start_wall, start_time, stop)
            if restart is None:
                stop.set()
                return
            if restart:
                start_wall, start_time = time.perf_counter(), 0.0
            spent = time.perf_counter() - tick_started
            # At most half of the time in frames: on a busy machine (or a slow one) the frames
            # come less often, the motion keeps its speed, and clicks still find the server free.
            stop.wait(max(period - spent, spent * IDLE_PER_BUSY))
