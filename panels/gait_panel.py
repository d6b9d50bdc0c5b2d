"""Gait panel: the symmetric DIRCON planner's settings (the gait paper's case by default),
Solve / Solve baseline / Cancel, live convergence, and the results beside the paper's Table 4."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import viser
import viser.uplot as uplot

from panels.quiet import set_value

if TYPE_CHECKING:
    from app.gait_session import GaitSession

PAPER_TABLE4 = {"max_abs_tau_Nm": (9.8, 11.5), "sr": (0.772, 1.299)}
"""Table 4 of the gait paper: (symmetric planner, previous planner)."""


class GaitPanel:
    """Owns the "Gait (DIRCON)" folder; callbacks only hand the settings to the session."""

    def __init__(self, gui: viser.GuiApi, session: GaitSession) -> None:
        self._gui = gui
        self.folder = gui.add_folder("Gait (DIRCON)", order=6, expand_by_default=False)
        with self.folder:
            self.robot_note = gui.add_markdown("")
            self.load_robot = gui.add_button(
                "Load dircon_biped", icon=viser.Icon.ROBOT, visible=False
            )
            self.slack = gui.add_multi_slider(
                "slack0 bounds [a, b]",
                min=-0.5,
                max=0.5,
                step=0.01,
                initial_value=(-0.05, 0.05),
                hint="Foothold slack: x1 = (0.5 + slack0)(x0 + x2), a ≤ slack0 ≤ b (paper: ±0.05). With "
                "identical legs and exchanged joint states the two steps mirror each other, so slack0 "
                "is 0: the bounds must include 0",
            )
            self.k0 = gui.add_slider("K0 energy", min=0.0, max=20.0, step=0.1, initial_value=6.5)
            self.k1 = gui.add_slider("K1 slack", min=0.0, max=20.0, step=0.1, initial_value=3.0)
            self.k2 = gui.add_slider(
                "K2 smoothness", min=0.0, max=20.0, step=0.1, initial_value=1.5
            )
            self.duration = gui.add_slider(
                "H, two steps [s]", min=0.3, max=2.0, step=0.01, initial_value=0.72
            )
            self.step = gui.add_slider(
                "advance, two steps [m]", min=0.0, max=0.6, step=0.01, initial_value=0.2
            )
            self.swing = gui.add_slider(
                "swing height ≤ [m]", min=0.02, max=0.2, step=0.005, initial_value=0.10
            )
            self.clearance = gui.add_slider(
                "swing clearance ≥ [m]",
                min=0.0,
                max=0.1,
                step=0.005,
                initial_value=0.04,
                hint="Lowest the swing sole may be at mid-swing (not in the paper: without it the "
                "optimum shuffles the foot along the floor)",
            )
            self.knots = gui.add_slider("knots", min=5, max=80, step=1, initial_value=38)
            self.mu = gui.add_slider("μ", min=0.1, max=1.5, step=0.05, initial_value=0.6)
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
            self.use = gui.add_button("Play this gait", icon=viser.Icon.WALK, disabled=True)

        @self.solve.on_click
        def _(event: viser.GuiEvent) -> None:
            session.solve(baseline=False, client=event.client)

        @self.baseline.on_click
        def _(event: viser.GuiEvent) -> None:
            session.solve(baseline=True, client=event.client)

        @self.cancel.on_click
        def _(_event: viser.GuiEvent) -> None:
            session.cancel()

        @self.use.on_click
        def _(_event: viser.GuiEvent) -> None:
            session.play_result()

        @self.load_robot.on_click
        def _(event: viser.GuiEvent) -> None:
            session.load_planner_robot(event.client)

        for handle in (
            self.slack,
            self.k0,
            self.k1,
            self.k2,
            self.duration,
            self.step,
            self.swing,
            self.clearance,
            self.knots,
            self.mu,
        ):
            handle.on_update(lambda _: session.settings_changed())

    def values(self) -> dict[str, float]:
        a, b = self.slack.value
        return {
            "slack_a": float(a),
            "slack_b": float(b),
            "K0": float(self.k0.value),
            "K1": float(self.k1.value),
            "K2": float(self.k2.value),
            "H_s": float(self.duration.value),
            "step_length_m": float(self.step.value),
            "swing_height_m": float(self.swing.value),
            "swing_clearance_m": float(self.clearance.value),
            "knots": int(self.knots.value),
            "mu": float(self.mu.value),
        }

    def show_running(self, running: bool) -> None:
        self.cancel.disabled = not running
        self.progress.visible = running

    def show_convergence(
        self, iterations: list[int], objective: list[float], violation: list[float]
    ) -> None:
        """Objective and constraint violation (log scale) per IPOPT iteration."""
        data = (
            np.asarray(iterations, dtype=float),
            np.log10(np.maximum(np.abs(objective), 1e-12)),
            np.log10(np.maximum(violation, 1e-16)),
        )
        if self.convergence is not None:
            self.convergence.data = data
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
