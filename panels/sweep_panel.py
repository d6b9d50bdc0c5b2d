"""Sweep panel: two swept parameters with their ranges, the sample count, two metrics to trade
off, Run / Cancel, progress, a Pareto scatter (uPlot) with the front highlighted, and a point
number to load that design and its gait into the studio.

The panel holds no sweep logic: its buttons call a `SweepActions` the session implements, and
the session reads the values back with `spec_values()`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import numpy as np
import viser
import viser.uplot as uplot

from panels.quiet import set_value

NONE = "(none)"
ALL_COLOUR = "#7f7f7f"
FRONT_COLOUR = "#d62728"


class SweepActions(Protocol):
    def run(self, client: viser.ClientHandle | None) -> None: ...
    def cancel(self) -> None: ...
    def load_point(self, client: viser.ClientHandle | None) -> None: ...


class SweepPanel:
    """Owns the "Sweep" folder."""

    def __init__(
        self,
        gui: viser.GuiApi,
        actions: SweepActions,
        parameters: Sequence[str],
        metrics: Sequence[str],
        defaults: dict[str, tuple[float, float]],
    ) -> None:
        """`parameters`: "kind:name" choices; `defaults[choice]` its initial (min, max)."""
        self._gui = gui
        self._defaults = defaults
        self.folder = gui.add_folder("Sweep", order=7, expand_by_default=False)
        with self.folder:
            gui.add_markdown(
                "Solve the gait at many designs (on Dask workers) and trade two metrics off."
            )
            first, second = parameters[0], parameters[1] if len(parameters) > 1 else NONE
            self.param_a = gui.add_dropdown("Parameter 1", tuple(parameters), initial_value=first)
            self.min_a = gui.add_number("1: min", defaults[first][0], step=0.001)
            self.max_a = gui.add_number("1: max", defaults[first][1], step=0.001)
            self.param_b = gui.add_dropdown(
                "Parameter 2", (NONE, *parameters), initial_value=second
            )
            lo, hi = defaults.get(second, (0.0, 0.0))
            self.min_b = gui.add_number("2: min", lo, step=0.001)
            self.max_b = gui.add_number("2: max", hi, step=0.001)
            self.samples = gui.add_number("Samples", 8, min=1, step=1, hint="Latin hypercube")
            self.knots = gui.add_number("Knots", 14, min=5, max=80, step=1, hint="Per gait")
            self.workers = gui.add_number("Workers", 2, min=1, max=64, step=1)
            self.metric_x = gui.add_dropdown(
                "Metric x (min)", tuple(metrics), initial_value=metrics[0]
            )
            self.metric_y = gui.add_dropdown(
                "Metric y (min)", tuple(metrics), initial_value=metrics[2]
            )
            self.run_button = gui.add_button("Run sweep")
            self.cancel_button = gui.add_button("Cancel sweep", disabled=True)
            self.status = gui.add_markdown("No sweep yet.")
            self.point = gui.add_number("Point #", 0, min=0, step=1, hint="From the table")
            self.load_button = gui.add_button("Load point", disabled=True)
        self.plot: viser.GuiUplotHandle | None = None
        self._plot_title = ""
        self.param_a.on_update(lambda _: self._reset_range(self.param_a, self.min_a, self.max_a))
        self.param_b.on_update(lambda _: self._reset_range(self.param_b, self.min_b, self.max_b))
        self.run_button.on_click(lambda event: actions.run(event.client))
        self.cancel_button.on_click(lambda _: actions.cancel())
        self.load_button.on_click(lambda event: actions.load_point(event.client))

    def show_spec(self, data: dict) -> None:
        """Show a sweep's data (as `spec_values` gives it, checked already): its parameters and
        ranges, samples, knots and metrics. Choices this panel does not offer are left as
        they are."""
        rows = (
            (self.param_a, self.min_a, self.max_a),
            (self.param_b, self.min_b, self.max_b),
        )
        parameters = list(data.get("parameter", []))
        for (choice, low, high), parameter in zip(rows, [*parameters, None], strict=False):
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
        metrics = list(dict(data.get("pareto", {})))
        for handle, metric in zip((self.metric_x, self.metric_y), metrics, strict=False):
            if metric in handle.options:
                set_value(handle, metric)

    def _reset_range(self, choice, low, high) -> None:
        if choice.value in self._defaults:
            low.value, high.value = self._defaults[choice.value]

    def spec_values(self) -> dict[str, object]:
        """The panel's choices as sweep-spec data (checked by SweepSpec.from_mapping)."""
        parameters = []
        for choice, low, high in (
            (self.param_a, self.min_a, self.max_a),
            (self.param_b, self.min_b, self.max_b),
        ):
            if choice.value == NONE:
                continue
            kind, name = str(choice.value).split(":", 1)
            parameters.append(
                {"kind": kind, "name": name, "min": float(low.value), "max": float(high.value)}
            )
        samples, knots = self.samples.value, self.knots.value
        return {
            "sampling": "latin",
            "samples": int(samples) if float(samples).is_integer() else samples,
            "gait": {"knots": int(knots) if float(knots).is_integer() else knots},
            "pareto": {str(self.metric_x.value): "min", str(self.metric_y.value): "min"},
            "parameter": parameters,
        }

    def running(self, running: bool) -> None:
        self.run_button.disabled = running
        self.cancel_button.disabled = not running

    def show_points(self, labels: tuple[str, str], xy: np.ndarray, front: np.ndarray) -> None:
        """Scatter of every solved point, xy shape (n, 2), with the front (bool (n,)) joined."""
        order = np.argsort(xy[:, 0], kind="stable")
        x, y = xy[order, 0], xy[order, 1]
        on = np.where(front[order], y, np.nan)
        data = (x, y, on)
        title = f"{labels[1]} vs {labels[0]}"
        if self.plot is not None and self._plot_title == title:
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
            uplot.Series(
                label="Pareto front",
                stroke=FRONT_COLOUR,
                width=1.5,
                spanGaps=True,
                points=uplot.Series_Points(show=True, size=8.0, fill=FRONT_COLOUR),
            ),
        )
        with self.folder:
            self.plot = self._gui.add_uplot(
                data,
                series,
                title=title,
                aspect=1.4,
                scales={"x": uplot.Scale(time=False)},
            )
        self._plot_title = title
