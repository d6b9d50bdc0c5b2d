"""Sweep panel: up to three swept parameters (robot, gait or servo) with their ranges, the sample
count, the simulation switch (with what it costs per point), two metrics to trade off, Run /
Cancel, progress with counts that add up (solved + failed + cancelled), the failed points with
their reasons, a Pareto scatter (uPlot) with the front highlighted, the designs that fell in the
simulation and the failed points (in a strip below) drawn apart, the point picked (by a click on
the plot in the 3D view, or by its number) with its parameters and metrics, and Load point for
that design, its gait and its servo settings.

The panel holds no sweep logic: its buttons call a `SweepActions` the session implements, and
the session reads the values back with `spec_values()`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Protocol

import numpy as np
import viser
import viser.uplot as uplot

from panels.quiet import Quiet, set_value
from panels.uplot_scale import scales_for

NONE = "(none)"
ALL_COLOUR = "#4c72b0"
FELL_COLOUR = "#1f1f1f"
FRONT_COLOUR = "#d62728"
FAILED_COLOUR = "#969696"
FAILURES_SHOWN = 12
"""Failed points listed in the panel (the rest counted)."""
ROWS = 3
"""Parameters one sweep of the panel may vary."""


class SweepActions(Protocol):
    def run(self, client: viser.ClientHandle | None) -> None: ...
    def cancel(self) -> None: ...
    def load_point(self, client: viser.ClientHandle | None) -> None: ...
    def select(self, index: int, client: viser.ClientHandle | None) -> None: ...
    def view_plot(self, client: viser.ClientHandle | None) -> None: ...


class SweepPanel:
    """Owns the "Sweep" folder."""

    def __init__(
        self,
        gui: viser.GuiApi,
        actions: SweepActions,
        parameters: Sequence[str],
        metrics: Sequence[str],
        defaults: dict[str, tuple[float, float]],
        robot_line: str,
        cost: Callable[[int], str],
        maximised: Sequence[str] = (),
    ) -> None:
        """`parameters`: "kind:name" choices (robot, gait and servo); `defaults[choice]` its
        initial (min, max); `robot_line`: which robot is swept (`offer` changes these three);
        `cost(steps)`: the simulation's cost per point, shown beside its switch; `maximised`:
        the metrics a front wants large (every other is minimised)."""
        self._gui = gui
        self._maximised = tuple(maximised)
        self._defaults = defaults
        self._cost = cost
        self.folder = gui.add_folder("Sweep", order=7, expand_by_default=False)
        with self.folder:
            gui.add_markdown(
                "Solve the gait at many designs (on Dask workers) and trade two metrics off."
            )
            self.robot_line = gui.add_markdown(robot_line)
            rows = []
            for i in range(ROWS):
                options, initial = _offered(i, parameters)
                lo, hi = defaults.get(initial, (0.0, 0.0))
                rows.append(
                    (
                        gui.add_dropdown(f"Parameter {i + 1}", options, initial_value=initial),
                        gui.add_number(f"{i + 1}: min", lo, step=0.001),
                        gui.add_number(f"{i + 1}: max", hi, step=0.001),
                    )
                )
            self.rows = tuple(rows)
            (self.param_a, self.min_a, self.max_a) = rows[0]
            (self.param_b, self.min_b, self.max_b) = rows[1]
            (self.param_c, self.min_c, self.max_c) = rows[2]
            self.samples = gui.add_number("Samples", 8, min=1, step=1, hint="Latin hypercube")
            self.knots = gui.add_number("Knots", 14, min=5, max=80, step=1, hint="Per gait")
            self.workers = gui.add_number("Workers", 2, min=1, max=64, step=1)
            self.simulate = gui.add_checkbox(
                "Simulate each point",
                False,
                hint="Walk, torques, servo commands and MuJoCo per point: the fall verdict, "
                "torso and tracking errors; needed by servo parameters and their metrics",
            )
            self.walk_steps = gui.add_number("Walk steps", 2, min=1, max=8, step=1)
            self.cost_line = gui.add_markdown(cost(2))
            better = "minimised" + (
                f"; {', '.join(maximised)} maximised (larger is better)" if maximised else ""
            )
            self.metric_x = gui.add_dropdown(
                "Metric x", tuple(metrics), initial_value=metrics[0], hint=better
            )
            self.metric_y = gui.add_dropdown(
                "Metric y", tuple(metrics), initial_value=metrics[2], hint=better
            )
            self.run_button = gui.add_button("Run sweep")
            self.cancel_button = gui.add_button("Cancel sweep", disabled=True)
            self.status = gui.add_markdown("No sweep yet.")
            self.failures = gui.add_markdown("")
            self.view_button = gui.add_button(
                "Pick on the plot in 3D",
                disabled=True,
                hint="Turns this tab's camera to the Pareto plot drawn beside the robot: click "
                "a point there to pick it",
            )
            self.point = gui.add_number(
                "Point #", 0, min=0, step=1, hint="Or click the point on the plot in the 3D view"
            )
            self.selected = gui.add_markdown("")
            self.load_button = gui.add_button("Load point", disabled=True)
        self.plot: viser.GuiUplotHandle | None = None
        self._plot_title = ""
        for row in self.rows:
            row[0].on_update(self._range_resetter(row))
        self.walk_steps.on_update(lambda _: self._show_cost())
        self.run_button.on_click(lambda event: actions.run(event.client))
        self.cancel_button.on_click(lambda _: actions.cancel())
        self.load_button.on_click(lambda event: actions.load_point(event.client))
        self.view_button.on_click(lambda event: actions.view_plot(event.client))
        self._quiet = Quiet()

        @self.point.on_update
        def _(event: viser.GuiEvent) -> None:
            if not self._quiet.is_quiet():
                value = self.point.value
                if np.isfinite(value) and float(value).is_integer():
                    actions.select(int(value), event.client)

    def offer(
        self,
        parameters: Sequence[str],
        defaults: dict[str, tuple[float, float]],
        robot_line: str,
    ) -> None:
        """Offer another robot's choices (as the constructor's arguments): the parameters start
        again as at the start, with their ranges."""
        self._defaults = defaults
        self.robot_line.content = robot_line
        for i, (choice, low, high) in enumerate(self.rows):
            options, initial = _offered(i, parameters)
            choice.options = options
            set_value(choice, initial)
            set_value(low, defaults.get(initial, (0.0, 0.0))[0])
            set_value(high, defaults.get(initial, (0.0, 0.0))[1])

    def offer_servos(self, defaults: dict[str, tuple[float, float]], robot_line: str) -> None:
        """The servos offered changed (the robot's choices otherwise the same): new first
        ranges and robot line; the rows keep what they hold."""
        self._defaults = defaults
        self.robot_line.content = robot_line

    def show_spec(self, data: dict) -> None:
        """Show a sweep's data (as `spec_values` gives it, checked already): its parameters and
        ranges, samples, knots and metrics. Choices this panel does not offer are left as
        they are."""
        parameters = list(data.get("parameter", []))
        padded = [*parameters, *[None] * ROWS][:ROWS]
        for (choice, low, high), parameter in zip(self.rows, padded, strict=True):
            if parameter is None:
                if NONE in choice.options:
                    set_value(choice, NONE)
                continue
            key = f"{parameter['kind']}:{parameter['name']}"
            if key in choice.options:
                set_value(choice, key)  # resets the range: set it after
                set_value(low, float(parameter["min"]))
                set_value(high, float(parameter["max"]))
        if "samples" in data:
            set_value(self.samples, data["samples"])
        knots = dict(data.get("gait", {})).get("knots")
        if knots is not None:
            set_value(self.knots, knots)
        set_value(self.simulate, bool(data.get("simulate", False)))
        if "walk_steps" in data:
            set_value(self.walk_steps, data["walk_steps"])
        metrics = list(dict(data.get("pareto", {})))
        for handle, metric in zip((self.metric_x, self.metric_y), metrics, strict=False):
            if metric in handle.options:
                set_value(handle, metric)

    def _range_resetter(self, row: tuple) -> Callable[[object], None]:
        return lambda _event: self._reset_range(*row)

    def _reset_range(self, choice, low, high) -> None:
        if choice.value in self._defaults:
            low.value, high.value = self._defaults[choice.value]

    def _show_cost(self) -> None:
        steps = self.walk_steps.value
        if np.isfinite(steps) and 1 <= steps <= 8:
            self.cost_line.content = self._cost(round(steps))

    def spec_values(self) -> dict[str, object]:
        """The panel's choices as sweep-spec data (checked by SweepSpec.from_mapping)."""
        parameters = []
        for choice, low, high in self.rows:
            if choice.value == NONE:
                continue
            kind, name = str(choice.value).split(":", 1)
            parameters.append(
                {"kind": kind, "name": name, "min": float(low.value), "max": float(high.value)}
            )
        samples, knots, steps = self.samples.value, self.knots.value, self.walk_steps.value
        data: dict[str, object] = {
            "sampling": "latin",
            "samples": _whole_or_as_is(samples),
            "gait": {"knots": _whole_or_as_is(knots)},
            "pareto": {
                str(handle.value): "max" if handle.value in self._maximised else "min"
                for handle in (self.metric_x, self.metric_y)
            },
            "parameter": parameters,
        }
        if self.simulate.value:
            data["simulate"] = True
            data["walk_steps"] = _whole_or_as_is(steps)
        return data

    def running(self, running: bool) -> None:
        self.run_button.disabled = running
        self.cancel_button.disabled = not running

    def show_selected(self, index: int, text: str, loadable: bool) -> None:
        """The point picked: its number in the box (without calling back), what it is, and
        whether Load point may load it."""
        with self._quiet.quietly():
            set_value(self.point, index)
        self.selected.content = text
        self.load_button.disabled = not loadable

    def show_failures(self, lines: Sequence[str]) -> None:
        """The failed points' one-line reasons (the first FAILURES_SHOWN, the rest counted)."""
        if not lines:
            self.failures.content = ""
            return
        shown = [f"- {line}" for line in lines[:FAILURES_SHOWN]]
        if len(lines) > FAILURES_SHOWN:
            shown.append(f"- … and {len(lines) - FAILURES_SHOWN} more (in the results table)")
        self.failures.content = f"**Failed points ({len(lines)}):**\n" + "\n".join(shown)

    def show_points(
        self,
        labels: tuple[str, str],
        xy: np.ndarray,
        kind: Sequence[str],
        fell: np.ndarray,
    ) -> None:
        """Scatter of every returned point, xy shape (n, 2), by `kind` (one of "design",
        "front", "fell", "failed" per point) and `fell` (bool (n,)): the solved designs that
        stayed up and those that fell in the simulation in their own series, the front joined
        over them, the failed ones in their strip below."""
        order = np.argsort(xy[:, 0], kind="stable")
        x, y = xy[order, 0], xy[order, 1]
        kinds, down = np.array(kind, dtype=object)[order], np.asarray(fell, dtype=bool)[order]
        solved = kinds != "failed"
        data = (
            x,
            np.where(solved & ~down, y, np.nan),
            np.where(solved & down, y, np.nan),
            np.where(kinds == "front", y, np.nan),
            np.where(~solved, y, np.nan),
        )
        title = f"{labels[1]} vs {labels[0]}"
        if self.plot is not None and self._plot_title == title:
            self.plot.scales = scales_for(*data)
            self.plot.data = data
            return
        if self.plot is not None:
            self.plot.remove()
        series = (
            uplot.Series(label=labels[0]),
            uplot.Series(
                label="designs",
                stroke=ALL_COLOUR,
                width=0.0,
                points=uplot.Series_Points(show=True, size=6.0, fill=ALL_COLOUR),
            ),
            _ringed("fell in simulation", FELL_COLOUR),
            uplot.Series(
                label="Pareto front",
                stroke=FRONT_COLOUR,
                width=1.5,
                spanGaps=True,
                points=uplot.Series_Points(show=True, size=8.0, fill=FRONT_COLOUR),
            ),
            _ringed("failed (strip below)", FAILED_COLOUR),
        )
        with self.folder:
            self.plot = self._gui.add_uplot(
                data,
                series,
                title=title,
                aspect=1.4,
                scales=scales_for(*data),
            )
        self._plot_title = title


def _offered(row: int, parameters: Sequence[str]) -> tuple[tuple[str, ...], str]:
    """A parameter row's options and first choice: the first two rows a parameter each, the
    rest none."""
    initial = parameters[row] if row < 2 and row < len(parameters) else NONE
    return (tuple(parameters) if row == 0 else (NONE, *parameters)), initial


def _whole_or_as_is(value: float) -> float | int:
    """A whole number as an int (the spec wants whole numbers there); anything else as it is,
    so the spec's check names it."""
    return int(value) if np.isfinite(value) and float(value).is_integer() else value


def _ringed(label: str, colour: str) -> uplot.Series:
    """Points alone, white with a `colour` ring: designs that fell or failed."""
    return uplot.Series(
        label=label,
        stroke=colour,
        width=0.0,
        points=uplot.Series_Points(show=True, size=7.0, fill="#ffffff", stroke=colour, width=2.0),
    )
