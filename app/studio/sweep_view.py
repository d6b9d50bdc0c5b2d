"""What the Sweep panel and the plots show of a sweep: its progress, its end, a restored sweep.

`SweepView` holds the panel and the picker (the plots: the panel's and the clickable Pareto board
in the 3D view) and writes the status lines; the session decides, the view shows.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import viser

from app.core.sweeps.evaluate import PointResult
from app.core.sweeps.outcomes import tally
from app.core.sweeps.results import SweepRecord
from app.core.sweeps.sampling import SweepPoint
from app.core.sweeps.spec import SweepSpec
from app.studio.sweep_choices import panel_data
from app.studio.sweep_picking import SweepPicker
from panels.sweep_panel import SweepPanel


class SweepView:
    """The panel's status line and the plots, for a sweep under way, ended, or restored."""

    def __init__(self, server: viser.ViserServer, panel: SweepPanel) -> None:
        self._server = server
        self.panel = panel
        self.picker = SweepPicker(server, panel)
        """The plots (the panel's and the clickable one in the 3D view) and the picked point."""
        self._starting = ""
        """The status line of the sweep starting (replaced, not kept, if it ends at once)."""

    def say(self, line: str) -> None:
        self.panel.status.content = line

    def warn(self, error: object) -> None:
        self.panel.status.content = f"⚠️ {error}"

    def starting(self, points: int, workers: int) -> None:
        self.picker.clear()
        self.panel.running(True)
        self._starting = f"Starting {points} points on {workers} worker{'s' * (workers != 1)}…"
        self.say(self._starting)

    def progress(
        self, spec: SweepSpec, results: list[PointResult], total: int, seconds: float
    ) -> None:
        counts = tally(results, total, spec.simulate)
        line = f"{counts.line()}, {counts.pending} to come; {len(results) / seconds:.2f} points/s"
        simulated = [r for r in results if r.solved and np.isfinite(r.fell)]
        if simulated:
            line += f" (simulation {np.mean([r.sim_s for r in simulated]):.1f} s/point)"
        self.say(line)
        with self._server.atomic():
            self.picker.show(spec, results)

    def finished(
        self,
        spec: SweepSpec,
        results: list[PointResult],
        total: int,
        front: tuple[int, ...],
        done: str,
        error: str,
    ) -> None:
        """The sweep ended (`done`: "done", "cancelled…"), with `error` where it failed."""
        counts = tally(results, total, spec.simulate, finished=True).line()
        line = f"Sweep {done}: {counts}; Pareto points: {_numbers(front)}."
        if error:
            self.say(f"⚠️ {error}  \n{line}")
        elif self.panel.status.content == self._starting:  # ended before its first result
            self.say(line)
        else:  # below the last progress line (its speed)
            self.say(f"{self.panel.status.content}  \n{line}")
        self.panel.running(False)
        self.picker.show(spec, results, final=True)
        if self.picker.selected is None:
            self.picker.pick_first(front, self.panel.point.value)

    def restored(
        self,
        record: SweepRecord,
        front: tuple[int, ...],
        loadable: bool,
        user_servos: tuple[Any, ...] = (),
    ) -> None:
        """A project's sweep: its spec in the panel (part:servo indices over the project's
        `user_servos` too), its points plotted; Load point is off while its points cannot be
        loaded (`loadable`: a URDF's sweep before that robot)."""
        spec, results = record.spec(), record.results
        self.panel.show_spec(panel_data(json.loads(record.spec_json), user_servos))
        solved = [r for r in results if r.solved]
        counts = tally(results, spec.n_points, spec.simulate, finished=True).line()
        self.say(
            f"From the project{' (cancelled)' if record.cancelled else ''}: {counts}; "
            f"Pareto points: {_numbers(front)}."
        )
        self.picker.show(spec, results, final=True)
        self.picker.pick_first(front, self.panel.point.value)
        if solved and not loadable:
            self.panel.load_button.disabled = True
            self.panel.status.content += (
                f"  \nLoad its points after loading {Path(spec.robot).name} (Robot panel)."
            )

    def prepared(self, point: SweepPoint, workers: int, robot: str) -> None:
        self.say(
            f"No sweep yet; {workers} workers ready with {Path(robot).name}'s "
            f"{point.settings.knots}-knot gait problem built."
        )


def _numbers(front: tuple[int, ...]) -> str:
    """The Pareto points' numbers as the panel's Point # box takes them: "#3, #7", or "none"."""
    return ", ".join(f"#{i}" for i in front) or "none"
