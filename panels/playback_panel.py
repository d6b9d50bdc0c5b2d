"""Playback panel: timeline, play/pause, speed, loop, traces, a camera that follows the robot,
and keyboard shortcuts (Space play/pause, J / L one frame back / forward).

The shortcuts are viser commands (also in its command palette, Ctrl+K). The arrow keys are not
used: viser's camera orbits on them whatever else they do."""

from __future__ import annotations

from typing import Protocol

import viser

from app.core.motions.trajectory import Trajectory
from panels.quiet import Quiet, set_value


class PlaybackActions(Protocol):
    """What the Playback panel asks for."""

    def seek(self, time_s: float) -> None: ...
    def toggle_play(self) -> None: ...
    def step(self, frames: int) -> None: ...
    def set_traces_visible(self, visible: bool) -> None: ...
    def set_follow(self, follow: bool) -> None: ...
    def set_speed(self, speed: float) -> None: ...
    def set_loop(self, loop: bool) -> None: ...


SPEEDS = ("0.25", "0.5", "1", "2")


class PlaybackPanel:
    """Owns the "Playback" folder. The player moves the timeline while playing."""

    def __init__(self, gui: viser.GuiApi, actions: PlaybackActions) -> None:
        with gui.add_folder("Playback", order=3):
            self.info = gui.add_markdown(
                "No motion yet: pick one in *Motions* or capture keyframes."
            )
            self.time = gui.add_slider(
                "Time [s]", min=0.0, max=1.0, step=0.01, initial_value=0.0, disabled=True
            )
            self.play = gui.add_button("Play", icon=viser.Icon.PLAYER_PLAY, disabled=True)
            self.speed = gui.add_dropdown("Speed", SPEEDS, initial_value="1")
            self.loop = gui.add_checkbox("Loop", True)
            self.traces = gui.add_checkbox("Show traces", True)
            self.follow = gui.add_checkbox(
                "Follow robot",
                False,
                hint="Keep the camera on the robot's pelvis as the motion plays (every tab)",
            )
            self.keys = gui.add_markdown("Keys: **Space** play / pause, **J** / **L** one frame.")
        self.commands = (
            gui.add_command("Play / pause", hotkey="space", icon=viser.Icon.PLAYER_PLAY),
            gui.add_command("Previous frame", hotkey="J", icon=viser.Icon.PLAYER_SKIP_BACK),
            gui.add_command("Next frame", hotkey="L", icon=viser.Icon.PLAYER_SKIP_FORWARD),
        )
        """Keyboard shortcuts, as commands of viser's palette."""
        self.commands[0].on_trigger(lambda _: actions.toggle_play())
        self.commands[1].on_trigger(lambda _: actions.step(-1))
        self.commands[2].on_trigger(lambda _: actions.step(1))
        self._quiet = Quiet()
        self.time.on_update(
            lambda _: None if self._quiet.is_quiet() else actions.seek(self.time.value)
        )
        self.play.on_click(lambda _: actions.toggle_play())
        self.traces.on_update(
            lambda _: (
                None if self._quiet.is_quiet() else actions.set_traces_visible(self.traces.value)
            )
        )
        self.follow.on_update(
            lambda _: None if self._quiet.is_quiet() else actions.set_follow(self.follow.value)
        )
        self.speed.on_update(
            lambda _: None if self._quiet.is_quiet() else actions.set_speed(self.speed_factor)
        )
        self.loop.on_update(
            lambda _: None if self._quiet.is_quiet() else actions.set_loop(bool(self.loop.value))
        )

    def show_none(self) -> None:
        self.time.disabled = True
        self.play.disabled = True
        self.show_playing(False)
        self.info.content = "No motion yet: pick one in *Motions* or capture keyframes."

    def show_trajectory(self, trajectory: Trajectory, summary: str) -> None:
        self.time.max = round(trajectory.duration, 2)
        self.time.step = max(0.01, round(trajectory.dt, 3))
        self.time.disabled = False
        self.play.disabled = False
        self.info.content = summary
        self.show_time(0.0)

    def show_time(self, time_s: float) -> None:
        """Move the timeline without seeking again."""
        with self._quiet.quietly():
            set_value(self.time, min(round(time_s, 2), self.time.max))

    def show_options(self, traces: bool, follow: bool, loop: bool, speed: float) -> None:
        """Set the toggles and the speed (a project's) without asking for anything."""
        with self._quiet.quietly():
            set_value(self.traces, traces)
            set_value(self.follow, follow)
            set_value(self.loop, loop)
            set_value(self.speed, f"{speed:g}" if f"{speed:g}" in SPEEDS else "1")

    def show_playing(self, playing: bool) -> None:
        label = "Pause" if playing else "Play"
        if self.play.label != label:  # called every frame: send only a change
            self.play.label = label
            self.play.icon = viser.Icon.PLAYER_PAUSE if playing else viser.Icon.PLAYER_PLAY

    @property
    def speed_factor(self) -> float:
        """The chosen speed; 1 for anything that is not one of the offered speeds."""
        return float(self.speed.value) if self.speed.value in SPEEDS else 1.0
