"""Design sweeps in the studio: the Sweep panel, a Dask engine, live progress and Pareto plot, and
loading a chosen point (its robot variant and a walk of its gait) into the state.

The sweep runs on a named thread, "sweep-runner", which starts the local Dask cluster the
first time (kept for later sweeps, closed with the studio; app/studio/sweep_workers.py) and
consumes results as they finish; `on_sweep_done` announces the end (finished or cancelled) with
the results. Loading a point (app/studio/sweep_loading.py) solves its gait on a worker, loads the
variant robot and plays a walk of its gait, on "sweep-loader"; `on_point_loaded` announces it.
Bad input (the panel's ranges, an unknown point) goes to the panel's status line and the
notifier, and the studio keeps its state.

Every point is counted once (`app.core.sweeps.outcomes`: done = solved + failed + cancelled),
failed points are listed with their one-line reason and drawn in the plots' failed strip, and a
point is picked by its number or by a click on the Pareto board in the 3D view (`SweepPicker`,
app/studio/sweep_picking.py); Load point loads the point picked. What the panel shows of a
sweep is written by `SweepView` (app/studio/sweep_view.py).

The panel sweeps the loaded robot (app/studio/sweep_choices.py): a built-in robot with sweep
parameters (servo_biped, dircon_biped) with its robot, gait and servo parameters; any other
robot (an uploaded URDF, a loaded sweep design) as its .urdf file, with gait and servo
parameters only. When the robot changes, the panel's choices and ranges start again for the new
robot and a running sweep is cancelled (its points so far stay shown, as the old robot's);
`on_choices` announces it. With `prepare=True` (what `serve` does) the workers are prepared for
every robot loaded once the studio has started (`workers.start_preparing`); `workers.on_prepared`
announces it.
"""

from __future__ import annotations

import dataclasses
import logging
import threading
import time
from pathlib import Path
from typing import Any

import viser

from app.core.errors import StudioError
from app.core.projects.project import Project
from app.core.sweeps.evaluate import PointResult
from app.core.sweeps.part_metrics import MAXIMISED
from app.core.sweeps.results import SweepRecord, pareto_indices
from app.core.sweeps.sampling import SweepPoint, start_point, sweep_points
from app.core.sweeps.spec import METRICS, SweepSpec
from app.studio.notifier import Notifier
from app.studio.signals import Signal
from app.studio.state import StudioState
from app.studio.sweep_choices import SweptRobot, choices, cost_line, ordered, whole
from app.studio.sweep_loading import PointLoader, ServoSettings
from app.studio.sweep_picking import SweepPicker
from app.studio.sweep_view import SweepView
from app.studio.sweep_workers import SweepWorkers
from panels.sweep_panel import SweepPanel
from robots.catalogue import BUILTIN_ROBOTS

log = logging.getLogger(__name__)


@dataclasses.dataclass(frozen=True)
class SweepOutcome:
    spec: SweepSpec
    results: tuple[PointResult, ...]
    pareto: tuple[int, ...]
    cancelled: bool
    error: str = ""


@dataclasses.dataclass
class _Running:
    """The sweep under way (its thread and engine run) and what was asked of it."""

    lock: threading.Lock = dataclasses.field(default_factory=threading.Lock)
    """Held while a sweep is checked and started."""
    thread: threading.Thread | None = None
    run: Any = None
    data: dict[str, object] = dataclasses.field(default_factory=dict)
    """The sweep data of the sweep under way (what SweepSpec.from_mapping took)."""
    cancelling: bool = False
    """Cancel was asked for the sweep under way (which may not have started its run yet)."""
    changed_to: str = ""
    """The robot loaded while the running sweep ran (which cancelled it), or ""."""

    def alive(self) -> bool:
        return self.thread is not None and self.thread.is_alive()


class SweepSession:
    """Owns the Sweep panel and the Dask engine of the studio's sweeps."""

    def __init__(
        self,
        server: viser.ViserServer,
        state: StudioState,
        notifier: Notifier,
        variants_dir: Path,
        servos: ServoSettings | None = None,
        prepare: bool = False,
        package_roots: tuple[Path, ...] = (),
    ) -> None:
        from app.core.collocation.settings import GaitSettings

        self._state = state
        self._notifier = notifier
        self._swept = SweptRobot(package_roots=tuple(str(root) for root in package_roots))
        self.workers = SweepWorkers(prepare, self._prepare_plan, self._prepared)
        """The Dask engine and the preparing of its workers (`start_preparing` once the studio
        has started; `prepared`, `prepared_s` and `on_prepared` say when and at what cost)."""
        self._loader = PointLoader(server, state, variants_dir, servos)
        self._running = _Running()
        self.outcome: SweepOutcome | None = None
        self.points: dict[int, SweepPoint] = {}
        self.record: SweepRecord | None = None
        """The last sweep as a project keeps it (None before the first result)."""
        self.on_sweep_done: Signal[SweepOutcome] = Signal("on_sweep_done")
        self.on_point_loaded: Signal[int] = Signal("on_point_loaded")
        self.on_result: Signal[PointResult] = Signal("on_result")
        """Each point's result as it arrives (after the panel shows it)."""
        self.on_choices: Signal[str] = Signal("on_choices")
        """The panel offers the choices of a newly loaded robot (its sweep robot)."""
        offered = choices("", GaitSettings())
        panel = SweepPanel(
            server.gui,
            self,
            ordered(offered),
            tuple(METRICS),
            offered,
            "Robot: none loaded yet.",
            cost_line,
            MAXIMISED,
        )
        self._view = SweepView(server, panel)
        state.on_robot.connect(self._on_robot)
        state.work.on_parts.connect(self._on_parts)

    @property
    def panel(self) -> SweepPanel:
        return self._view.panel

    @property
    def picker(self) -> SweepPicker:
        """The plots (the panel's and the clickable one in the 3D view) and the picked point."""
        return self._view.picker

    # --- the robot swept and the workers -------------------------------------------------------

    def _on_robot(self, loaded: Any) -> None:
        """A robot loaded: sweep it. The panel's choices start again for it; a running sweep
        (of the robot before) is cancelled."""
        robot = loaded.robot
        self._swept = swept = SweptRobot.of(
            robot, self._swept.package_roots, self._swept.user_servos
        )
        if self._running.alive():
            self._running.changed_to = robot.name
            self.cancel()
        self.picker.place(robot)
        offered = choices(swept.robot, swept.shown_defaults(), swept.user_servos)
        self.panel.offer(ordered(offered), offered, swept.line())
        self.on_choices.emit(swept.robot)
        self.workers.robot_loaded()

    def _on_parts(self, choice: Any) -> None:
        """The servo parts changed: the project's own servo files join part:servo's choices."""
        if choice.user_servos == self._swept.user_servos:
            return
        self._swept = swept = dataclasses.replace(self._swept, user_servos=choice.user_servos)
        offered = choices(swept.robot, swept.shown_defaults(), swept.user_servos)
        self.panel.offer_servos(offered, swept.line())

    def _prepare_plan(self) -> tuple[SweepPoint, int] | None:
        """The anchor point to prepare at the panel's knots, and the panel's workers; None
        while a sweep runs (its points build what they need)."""
        if self._running.alive():
            return None
        swept = self._swept
        defaults = swept.planner_defaults()
        values = self.panel.spec_values()
        try:
            spec = SweepSpec.from_mapping(swept.spec_data(values), "sweep panel")
        except StudioError:  # the panel holds a bad sweep: prepare its knots anyway
            knots = dict(values.get("gait", {})).get("knots", 14)  # type: ignore[call-overload]
            spec = SweepSpec.from_mapping(
                swept.spec_data(
                    {
                        "gait": {"knots": knots},
                        "parameter": [{"name": "H_s", "min": 0.7, "max": 0.7}],
                    }
                )
            )
        return start_point(spec, defaults), whole(self.panel.workers.value, "workers")

    def _prepared(self, point: SweepPoint) -> None:
        if self.outcome is None and not self._running.alive():
            self._view.prepared(point, len(self.workers.prepared_s), point.robot.robot)

    # --- running ------------------------------------------------------------------------------

    def run(self, client: viser.ClientHandle | None = None) -> None:
        """Check the panel's sweep and start it; a bad one is refused with the reason."""
        running = self._running
        with running.lock:
            if running.alive():
                return
            try:
                data = self.panel_sweep()
                spec = SweepSpec.from_mapping(data, "sweep panel")
                workers = whole(self.panel.workers.value, "workers")
                points = sweep_points(spec, self._swept.planner_defaults())
            except StudioError as error:
                self._view.warn(error)
                self._notifier.error("Cannot run this sweep", str(error), client)
                return
            running.cancelling, running.changed_to = False, ""
            self._view.starting(len(points), workers)
            running.data = data
            running.thread = threading.Thread(
                target=self._sweep, args=(spec, points, workers, client), name="sweep-runner"
            )
            running.thread.start()

    def panel_sweep(self) -> dict[str, Any]:
        """The sweep data the panel's rows make now, for the robot swept and the project's
        own servo files (what Run checks); StudioError for rows that make none."""
        return self._swept.spec_data(self.panel.spec_values())

    def cancel(self) -> None:
        self._running.cancelling = True  # before reading the run: a run starting now sees it
        run = self._running.run
        if run is not None:
            run.cancel()

    def _sweep(self, spec: SweepSpec, points: list[SweepPoint], workers: int, client: Any) -> None:
        running = self._running
        results: list[PointResult] = []
        error = ""
        cancelled = False
        start = time.perf_counter()
        try:
            engine = self.workers.engine_for(workers)
            running.run = run = engine.start(points)
            if running.cancelling:  # cancelled while the engine started
                run.cancel()
            for result in run.results():
                results.append(result)
                self._view.progress(spec, results, len(points), time.perf_counter() - start)
                self.on_result.emit(result)
            cancelled = run.cancelled
        except StudioError as failure:
            error = str(failure)
            self._notifier.error("The sweep failed", error, client)
        except Exception as failure:  # a thread boundary: report, and give the panel back
            log.exception("the sweep failed")
            error = f"the sweep failed: {type(failure).__name__}: {failure}"
            self._notifier.error("The sweep failed", error, client)
        finally:
            running.run = None
        front = tuple(pareto_indices(spec, results))
        self.points = {p.index: p for p in points}
        self.outcome = SweepOutcome(spec, tuple(results), front, cancelled, error)
        self.record = SweepRecord.of(running.data, results, cancelled) if results else None
        done = "cancelled" if cancelled else "done"
        if cancelled and running.changed_to:
            done += f" (the robot changed to {running.changed_to}; these points are {spec.robot}'s)"
        running.changed_to = ""
        self._view.finished(spec, results, len(points), front, done, error)
        self.on_sweep_done.emit(self.outcome)

    # --- loading a point ----------------------------------------------------------------------

    def select(self, index: int, client: viser.ClientHandle | None = None) -> None:
        """Pick point `index` (its number typed in the panel, or a click on the plot)."""
        self.picker.select(index, client)

    def view_plot(self, client: viser.ClientHandle | None = None) -> None:
        """Turn the tab's camera to the clickable Pareto plot in the 3D view."""
        self.picker.view(client)

    def load_point(self, client: viser.ClientHandle | None = None) -> None:
        """Load the chosen point's robot and play a walk of its gait, on "sweep-loader"."""
        outcome, engine = self.outcome, self.workers.engine
        try:
            index = whole(self.panel.point.value, "Point #")
            if outcome is None:
                raise StudioError("run a sweep first")
            result = next((r for r in outcome.results if r.index == index), None)
            if result is None or not result.solved:
                solved = [r.index for r in outcome.results if r.solved]
                raise StudioError(f"point {index} has no gait; solved points: {solved}")
            if index not in self.points:
                robot = Path(outcome.spec.robot).name
                raise StudioError(f"point {index} is of {robot}: load that robot first")
        except StudioError as error:
            self._view.warn(error)
            self._notifier.error("Cannot load this point", str(error), client)
            return
        point = self.points[index]
        threading.Thread(
            target=self._load, args=(engine, point, client), name="sweep-loader"
        ).start()

    def _load(self, engine: Any, point: SweepPoint, client: Any) -> None:
        try:
            if engine is None:  # a sweep restored from a project: start the workers now
                engine = self.workers.engine_for(1)
            outcome = self.outcome
            self._loader.load(engine, point, outcome.spec.user_servos if outcome else ())
        except Exception as error:  # a thread boundary: bad input, or a worker lost meanwhile
            if not isinstance(error, StudioError):
                log.exception("loading a sweep point failed")
            self._view.warn(error)
            self._notifier.error("Cannot load this point", str(error), client)
            return
        self.panel.status.content += f"  \nLoaded point #{point.index}."
        self.on_point_loaded.emit(point.index)

    # --- projects ------------------------------------------------------------------------------

    def snapshot(self) -> dict[str, object]:
        return {"sweep": self.record}

    def restore(self, project: Project) -> None:
        """Show the project's sweep: its points, the Pareto plot, and Load point for its
        solved points (re-solved on demand; the points are rebuilt from the spec)."""
        record = project.sweep
        self.record = record
        if record is None:
            return
        spec = record.spec()  # checked when the project was read
        results = record.results
        front = tuple(pareto_indices(spec, results))
        if spec.robot in BUILTIN_ROBOTS:
            self.points = {p.index: p for p in sweep_points(spec)}
        elif spec.robot == self._swept.robot:  # a URDF's sweep: the file is read only as loaded
            self.points = {p.index: p for p in sweep_points(spec, self._swept.planner_defaults())}
        else:
            self.points = {}
        self.outcome = SweepOutcome(spec, results, front, record.cancelled)
        self._view.restored(
            record, front, loadable=bool(self.points), user_servos=self._swept.user_servos
        )

    def close(self) -> None:
        self.cancel()
        thread = self._running.thread
        if thread is not None:
            thread.join(30.0)
        self.workers.close()
