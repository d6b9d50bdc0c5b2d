"""The Sweep panel's plots and its picked point: what the sweep session shows of its results.

`SweepPicker` draws the returned points (the panel's uPlot scatter and the clickable Pareto
board in the 3D view, from the same `plot_points`), lists the failed points with their
reasons, and keeps the point picked, by a click on the board or by its number typed in the
panel: the panel shows its parameters and metrics (or why it failed) and enables Load point
when it has a gait. `on_selected` announces each pick.
"""

from __future__ import annotations

import threading
from collections.abc import Sequence
from typing import Any

import numpy as np
import viser

from app.core.sweeps.evaluate import PointResult
from app.core.sweeps.outcomes import failures, outcome_of
from app.core.sweeps.plot_points import PlotPoints, plot_points
from app.core.sweeps.spec import SweepSpec
from app.studio.signals import Signal
from app.views.pareto_board import ParetoBoard
from panels.sweep_panel import SweepPanel

BOARD_ROOT = "/sweep_pareto"
CAMERA_TOWARD = np.array([0.95, 0.7, 0.0])
"""Where the studio's first camera stands from the robot (robot_session's framing): the board
faces it."""


class SweepPicker:
    """The plots of the last sweep and the point picked on them."""

    def __init__(self, server: viser.ViserServer, panel: SweepPanel) -> None:
        self._server = server
        self._panel = panel
        self._lock = threading.Lock()
        self.board = ParetoBoard(server, BOARD_ROOT, self.select)
        self._spec: SweepSpec | None = None
        self._results: dict[int, PointResult] = {}
        self._plotted: PlotPoints | None = None
        self._final = False
        """The points shown are of a sweep that has ended (they may be loaded)."""
        self.selected: int | None = None
        self.on_selected: Signal[int] = Signal("on_selected")
        """A point was picked (by a click on the board or by its number)."""

    def place(self, robot: Any) -> None:
        """Stand the board beside `robot` (its standing height), facing the first camera."""
        lower, upper = robot.bounds_m(robot.q_neutral, robot.model.createData())
        height = max(float(upper[2] - min(lower[2], 0.0)), 0.3)
        centre = 0.5 * (lower + upper)
        toward = CAMERA_TOWARD / np.linalg.norm(CAMERA_TOWARD)
        right = np.array([-toward[1], toward[0], 0.0])
        origin = np.array([centre[0], centre[1], 0.0]) + 0.6 * height * right
        origin += -0.3 * height * toward + np.array([0.0, 0.0, 0.05 * height])
        self.board.place(origin, toward, 0.9 * height)
        with self._lock:
            plotted, selected = self._plotted, self.selected
        if plotted is not None:
            self.board.draw(plotted, selected)

    def show(self, spec: SweepSpec, results: Sequence[PointResult], final: bool = False) -> None:
        """Draw the returned points and list the failed ones; the pick is kept if it is one.
        `final`: the sweep has ended (its points may be loaded; not while it runs)."""
        plotted = plot_points(spec, results)
        by_index = {r.index: r for r in results}
        with self._lock:
            self._spec, self._plotted, self._results = spec, plotted, by_index
            self._final = final
            selected = self.selected
        lines = [
            f"#{o.index} ({_values(spec, by_index[o.index])}): {o.line()}"
            for o in failures(results, spec.simulate)
        ]
        self._panel.show_failures(lines)
        if len(plotted.index):
            self._panel.show_points(plotted.labels, plotted.xy, plotted.kind, plotted.fell)
            self.board.draw(plotted, selected)
        self._panel.view_button.disabled = not len(plotted.index)
        if selected is not None and selected in self._results:
            self._show(selected)

    def clear(self) -> None:
        """A new sweep starts: no points, no pick."""
        with self._lock:
            self._results, self._plotted, self.selected = {}, None, None
            self._final = False
        self.board.remove()
        self._panel.load_button.disabled = True
        self._panel.show_failures([])
        self._panel.selected.content = ""
        self._panel.view_button.disabled = True

    def select(self, index: int, client: Any = None) -> None:
        """Pick point `index`: the panel shows it (or why there is none), the board rings it."""
        with self._lock:
            self.selected = index
        self._show(index)
        self.board.select(index)
        self.on_selected.emit(index)

    def pick_first(self, front: Sequence[int], typed: float) -> None:
        """Pick a point of a sweep just shown: the first of its Pareto front, else the point
        whose number is typed if it came back, else the first point back (so the panel always
        says what its number is)."""
        with self._lock:
            back = sorted(self._results)
        if front:
            self.select(front[0])
        elif back:
            self.select(int(typed) if typed in back else back[0])

    def _show(self, index: int) -> None:
        with self._lock:
            spec, result, plotted = self._spec, self._results.get(index), self._plotted
            final = self._final
        if spec is None:
            self._panel.show_selected(index, "Run a sweep first, then pick a point.", False)
        elif result is None:
            self._panel.show_selected(
                index, f"No point #{index} back from the sweep (points 0–{spec.n_points - 1}).",
                False,
            )  # fmt: skip
        else:
            front = plotted is not None and plotted.kind_of(index) == "front"
            text = _describe(spec, result, front)
            if result.solved and not final:
                text += "  \n(Load it once the sweep has ended.)"
            self._panel.show_selected(index, text, result.solved and final)

    def view(self, client: Any) -> None:
        """Turn `client`'s camera to the board."""
        if client is None:
            return
        camera = client.camera
        position, look_at = self.board.view(float(camera.fov), float(camera.aspect))
        with client.atomic():
            camera.up_direction = (0.0, 0.0, 1.0)
            camera.position = position  # moves look_at along: set it after
            camera.look_at = look_at


def _values(spec: SweepSpec, result: PointResult) -> str:
    return ", ".join(
        f"{p.name} = {p.shown(v)}" for p, v in zip(spec.parameters, result.values, strict=True)
    )


def _describe(spec: SweepSpec, result: PointResult, front: bool) -> str:
    """The picked point in two lines: its parameters, then its metrics or why it failed."""
    outcome = outcome_of(result, spec.simulate)
    head = f"**Point #{result.index}**{' (Pareto front)' if front else ''}: {_values(spec, result)}"
    if outcome.failed:
        tail = f"failed ({outcome.stage}): {outcome.reason}"
        if result.solved:
            tail += " (its gait can still be loaded)"
        return f"{head}  \n{tail}"
    metrics = [m for m, _ in spec.pareto] + [
        m for m in ("sr", "max_torque_Nm") if m not in dict(spec.pareto)
    ]
    tail = ", ".join(f"{m} {result.metric(m):.4g}" for m in metrics)
    if spec.simulate:
        tail += f"; simulation: {result.sim_status}"
        if result.sim_notes:
            tail += f"  \nnote: {result.sim_notes}"
    return f"{head}  \n{tail}"
