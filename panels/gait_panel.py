"""Gait panel: the DIRCON planner's settings (sliders built from app.core.collocation.controls,
the gait paper's case by default), Solve / Solve baseline / Cancel, live convergence, and the
results beside the paper's Table 4."""

from __future__ import annotations

from typing import Protocol

import numpy as np
import viser
import viser.uplot as uplot

from app.core.collocation.controls import CONTROLS, SLACK_HINT, SLACK_RANGE, settings_with
from app.core.collocation.settings import GaitSettings
from panels.clicks import bind_clicks
from panels.quiet import Quiet, set_value


class GaitActions(Protocol):
    """What the Gait panel asks for."""

    def solve(self, baseline: bool, client: viser.ClientHandle | None) -> str | None: ...
    def cancel(self) -> None: ...
    def play_result(self, client: viser.ClientHandle | None) -> None: ...
    def pipeline(self, client: viser.ClientHandle | None) -> None: ...
    def load_planner_robot(self, client: viser.ClientHandle | None) -> None: ...
    def settings_changed(self) -> None: ...


class GaitPanel:
    """Owns the "Gait (DIRCON)" folder; callbacks only hand the settings to the session."""

    def __init__(self, gui: viser.GuiApi, actions: GaitActions) -> None:
        self._gui = gui
        self._quiet = Quiet()
        self._base = GaitSettings()
        self._plannable, self._running = True, False
        self.folder = gui.add_folder("Gait (DIRCON)", order=6, expand_by_default=False)
        with self.folder:
            self.robot_note = gui.add_markdown("")
            self.load_robot = gui.add_button(
                "Load the paper's robot (dircon_biped)", icon=viser.Icon.ROBOT, visible=False
            )
            low, high, step = SLACK_RANGE
            self.slack = gui.add_multi_slider(
                "slack0 bounds [a, b]",
                min=low,
                max=high,
                step=step,
                initial_value=(self._base.slack_a, self._base.slack_b),
                hint=SLACK_HINT,
            )
            self.sliders: dict[str, viser.GuiSliderHandle] = {
                c.field: gui.add_slider(
                    c.label,
                    min=c.minimum,
                    max=c.maximum,
                    step=c.step,
                    initial_value=getattr(self._base, c.field),
                    hint=c.hint or None,
                )
                for c in CONTROLS
            }
            self.solve = gui.add_button("Solve", icon=viser.Icon.PLAYER_PLAY)
            self.baseline = gui.add_button(
                "Solve baseline (original DIRCON)", icon=viser.Icon.PLAYER_PLAY
            )
            self.cancel = gui.add_button(
                "Cancel", icon=viser.Icon.PLAYER_STOP, color="red", disabled=True
            )
            self.progress = gui.add_progress_bar(0.0, visible=False, animated=True)
            self.status = gui.add_markdown(
                "Set the gait, then Solve (the worker builds the problem once)."
            )
            self.convergence: viser.GuiUplotHandle | None = None
            self.results = gui.add_markdown("")
            self.steps = gui.add_slider(
                "walk: steps",
                min=1,
                max=20,
                step=1,
                initial_value=4,
                hint="Steps of the planned gait to walk, from standing to standing",
            )
            self.use = gui.add_button("Walk this gait", icon=viser.Icon.WALK, disabled=True)
            self.all_stages = gui.add_button(
                "Plan → walk → torques → simulate",
                icon=viser.Icon.PLAYER_TRACK_NEXT,
                hint="One click: plan the gait (unless the last one still fits the sliders), walk "
                "it, compute its torques and compensation, and simulate it; each stage reports "
                "in its own panel",
            )

        bind_clicks(
            (self.solve, lambda client: actions.solve(baseline=False, client=client)),
            (self.baseline, lambda client: actions.solve(baseline=True, client=client)),
            (self.use, actions.play_result),
            (self.all_stages, actions.pipeline),
            (self.load_robot, actions.load_planner_robot),
        )
        self.cancel.on_click(lambda _: actions.cancel())

        for handle in (self.slack, *self.sliders.values()):
            handle.on_update(
                lambda _: None if self._quiet.is_quiet() else actions.settings_changed()
            )

    def values(self) -> dict[str, float]:
        """The sliders' values by GaitSettings field."""
        a, b = self.slack.value
        values = {"slack_a": float(a), "slack_b": float(b)}
        values.update({name: float(handle.value) for name, handle in self.sliders.items()})
        return values

    def settings(self, baseline: bool) -> GaitSettings:
        """The settings the sliders describe (GaitSettingsError if they describe no gait)."""
        return settings_with(self._base, {**self.values(), "baseline": baseline})

    def show_settings(self, settings: GaitSettings) -> None:
        """Show a robot's default settings without calling back."""
        self._base = settings
        with self._quiet.quietly():
            set_value(self.slack, (settings.slack_a, settings.slack_b))
            for name, handle in self.sliders.items():
                set_value(handle, float(np.clip(getattr(settings, name), handle.min, handle.max)))

    def show_plannable(self, plannable: bool) -> None:
        """Whether the loaded robot can be planned for (else Solve is off)."""
        self._plannable = plannable
        self._enable_solves()

    def show_running(self, running: bool) -> None:
        """A solve runs (every tab sees it): Cancel on, the progress bar shown, the Solve
        buttons off until it ends."""
        self._running = running
        self.cancel.disabled = not running
        self.progress.visible = running
        self._enable_solves()

    def _enable_solves(self) -> None:
        off = not self._plannable or self._running
        self.solve.disabled = off
        self.baseline.disabled = off
        self.all_stages.disabled = off

    def show_convergence(
        self, iterations: list[int], objective: list[float], violation: list[float]
    ) -> None:
        """Objective and constraint violation (log scale) per IPOPT iteration. A solve that
        ended before its first iteration (cancelled while the worker built the NLP) hides the
        chart instead: uPlot in the page never draws again once handed empty series, so every
        open tab's chart stayed blank for all later solves until the page was reloaded."""
        if not iterations:
            if self.convergence is not None:
                self.convergence.visible = False
            return
        data = (
            np.asarray(iterations, dtype=float),
            np.log10(np.maximum(np.abs(objective), 1e-12)),
            np.log10(np.maximum(violation, 1e-16)),
        )
        if self.convergence is not None:
            self.convergence.data = data
            self.convergence.visible = True
            return
        series = (
            uplot.Series(label="iteration"),
            uplot.Series(label="log10 |objective|", stroke="#1f77b4", width=1.5),
            uplot.Series(label="log10 violation", stroke="#d62728", width=1.5),
        )
        with self.folder:
            self.convergence = self._gui.add_uplot(
                data,
                series,
                title="IPOPT convergence",
                aspect=2.0,
                scales={"x": uplot.Scale(time=False)},
                order=self.status.order + 0.01,
            )

    def show_progress(self, fraction: float) -> None:
        set_value(self.progress, 100.0 * min(max(fraction, 0.0), 1.0))
