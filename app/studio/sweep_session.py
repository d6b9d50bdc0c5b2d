"""Design sweeps in the studio: the Sweep panel, a Dask engine, live progress and Pareto plot, and
loading a chosen point (its robot variant and a walk of its gait) into the state.

The sweep runs on a named thread, "sweep-runner", which starts the local Dask cluster the
first time (kept for later sweeps, closed with the studio) and consumes results as they finish;
`on_sweep_done` announces the end (finished or cancelled) with the results. Loading a point
solves its gait on a worker (the NLP is warm there), loads the variant robot with
`StudioState.set_robot` and plays a walk of the gait with `set_motion`, on "sweep-loader";
`on_point_loaded` announces it; a point of a simulated sweep also hands its servo settings (the
compliance, dead band and compensation it was simulated with) to the Compensation panel through
the `servos` callback. Bad input (the panel's ranges, an unknown point) goes to the panel's
status line and the notifier, and the studio keeps its state.

Every point is counted once (`app.core.sweeps.outcomes`: done = solved + failed + cancelled),
failed points are listed with their one-line reason and drawn in the plots' failed strip, and a
point is picked by its number or by a click on the Pareto board in the 3D view (`SweepPicker`,
app/studio/sweep_picking.py); Load point loads the point picked.

The panel sweeps the loaded robot: a built-in robot with sweep parameters (servo_biped,
dircon_biped) with its robot, gait and servo parameters; any other robot (an uploaded URDF, a
loaded sweep design) as its .urdf file, with gait and servo parameters only. When the robot
changes, the panel's choices and ranges start again for the new robot and a running sweep is
cancelled (its points so far stay shown, as the old robot's); `on_choices` announces it.

Prepared workers (`prepare=True`, what `serve` does): once the studio has started
(`start_preparing`, so its start is not slowed) and whenever a robot loads, a low-priority
thread, "sweep-prepare", starts the local cluster (its worker processes niced) and has every
worker build the loaded robot's gait NLP at the panel's knots and solve its anchor gait, so the
first point of a sweep pays only its solve; `on_prepared` announces it.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import logging
import os
import threading
import time
from collections.abc import Callable
from concurrent.futures import CancelledError
from pathlib import Path
from typing import Any

import numpy as np
import viser

from app.core.collocation.controls import CONTROLS
from app.core.errors import StudioError
from app.core.projects.project import Project
from app.core.sweeps.evaluate import PointResult
from app.core.sweeps.outcomes import tally
from app.core.sweeps.results import SweepRecord, pareto_indices
from app.core.sweeps.robot_variants import ROBOT_PARAMETERS, sweep_robot_of
from app.core.sweeps.sampling import SweepPoint, start_point, sweep_points
from app.core.sweeps.servo_metrics import SERVO_PARAMETERS, servo_settings, simulation_cost_s
from app.core.sweeps.spec import METRICS, SweepSpec
from app.studio.notifier import Notifier
from app.studio.signals import Signal
from app.studio.state import StudioState
from app.studio.sweep_picking import SweepPicker
from panels.sweep_panel import SweepPanel
from robots.catalogue import BUILTIN_ROBOTS

log = logging.getLogger(__name__)

STEP_RANGE = (0.6, 1.4)
"""The panel's first step-length range, × the robot's default step (the planner's defaults
scale with the legs): dircon_biped's 0.2 m gives 0.12–0.28 m."""
H_RANGE = (0.6 / 0.72, 0.9 / 0.72)
"""The panel's first gait-time range, × the robot's default H: dircon_biped's 0.72 s gives
0.6–0.9 s."""
WALK_STEPS = 4
WORKER_NICENESS = 10
"""The studio's sweep workers run below the studio itself, so a sweep (and the preparing of
one) leaves the studio responsive."""
ServoSettings = Callable[[Any, Any], None]
"""Takes (CompensationParams, ServoModel) for the loaded robot: the Compensation panel's."""


@dataclasses.dataclass(frozen=True)
class SweepOutcome:
    spec: SweepSpec
    results: tuple[PointResult, ...]
    pareto: tuple[int, ...]
    cancelled: bool
    error: str = ""


def _choices(robot: str, defaults: Any) -> dict[str, tuple[float, float]]:
    """The panel's parameters for sweep robot `robot` (sweep_robot_of) with their first ranges:
    step length and gait time around the robot's planner `defaults`, the other gait settings
    over their sliders' ranges, a built-in's robot parameters over what its builder accepts."""
    out = {f"gait:{c.field}": (float(c.minimum), float(c.maximum)) for c in CONTROLS}
    step, h = defaults.step_length_m, defaults.H_s
    out["gait:step_length_m"] = (round(step * STEP_RANGE[0], 4), round(step * STEP_RANGE[1], 4))
    out["gait:H_s"] = (round(h * H_RANGE[0], 3), round(h * H_RANGE[1], 3))
    for p in ROBOT_PARAMETERS.get(robot, {}).values():
        out[f"robot:{p.name}"] = (p.minimum, p.maximum)
    for s in SERVO_PARAMETERS.values():
        out[f"servo:{s.name}"] = (s.minimum, s.maximum)
    return out


def _ordered(choices: dict[str, tuple[float, float]]) -> list[str]:
    first = ["gait:step_length_m", "gait:H_s"]
    return first + [c for c in choices if c not in first]


def _robot_line(robot: str, name: str) -> str:
    """Which robot the panel sweeps, and why robot parameters are missing where they are."""
    if robot in ROBOT_PARAMETERS:
        return f"Robot: **{robot}** (the loaded robot) and its variants."
    if robot.lower().endswith(".urdf"):
        why = (
            "its links have no known segment axis or shape to stretch, so no robot "
            "parameters (gait and servo only)"
        )
        return f"Robot: **{name}** (`{Path(robot).name}`, the loaded robot): {why}."
    return f"Robot: **{robot}** (the loaded robot): its builder has no sweep parameters."


def _cost_line(steps: int) -> str:
    return (
        f"Simulating costs ~{simulation_cost_s(steps):.1f} s more per point ({steps} "
        f"step{'' if steps == 1 else 's'}; "
        "the progress line shows what it took)."
    )


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
        self._server = server
        self._package_roots = tuple(str(root) for root in package_roots)
        """The studio's --package-root folders: a swept .urdf robot's workers load with them."""
        self._feet: tuple[str, str] | None = None
        """The loaded robot's (left, right) foot links: a swept .urdf robot's workers use them."""
        self._servos = servos
        self._prepare = prepare
        self._prepare_lock = threading.Lock()
        """Guards the two below: at most one "sweep-prepare" thread runs."""
        self._preparer: threading.Thread | None = None
        self._prepare_wanted = False
        """A robot loaded since the preparer started its round: it goes round again."""
        self._engine_lock = threading.Lock()
        """Held while the engine is made or replaced (the runner, the preparer, the loader)."""
        self._closed = False
        self._robot = ""
        """The robot the panel sweeps (sweep_robot_of the loaded robot; "" before one)."""
        self._defaults: Any = None
        """The loaded robot's planner defaults (GaitSettings), or the StudioError why the
        planner cannot walk it."""
        self.prepared_s: dict[str, float] = {}
        """What the last preparing cost each worker [s] (0.0 where it was warm)."""
        self.on_prepared: Signal[dict[str, float]] = Signal("on_prepared")
        self.prepared = threading.Event()
        """Set when the workers have been prepared once (`prepared_s` says what it cost)."""
        self._variants_dir = variants_dir
        """Where the URDFs of loaded sweep designs are kept (the data folder's variants/)."""
        self._state = state
        self._notifier = notifier
        self._lock = threading.Lock()
        self._engine: Any = None
        self._run: Any = None
        self._thread: threading.Thread | None = None
        self.outcome: SweepOutcome | None = None
        self.points: dict[int, SweepPoint] = {}
        self.record: SweepRecord | None = None
        """The last sweep as a project keeps it (None before the first result)."""
        self._data: dict[str, object] = {}
        """The sweep data of the sweep under way (what SweepSpec.from_mapping took)."""
        self.on_sweep_done: Signal[SweepOutcome] = Signal("on_sweep_done")
        self.on_point_loaded: Signal[int] = Signal("on_point_loaded")
        self.on_result: Signal[PointResult] = Signal("on_result")
        """Each point's result as it arrives (after the panel shows it)."""
        self.on_choices: Signal[str] = Signal("on_choices")
        """The panel offers the choices of a newly loaded robot (its sweep robot)."""
        from app.core.collocation.settings import GaitSettings

        choices = _choices("", GaitSettings())
        self.panel = SweepPanel(
            server.gui,
            self,
            _ordered(choices),
            tuple(METRICS),
            choices,
            "Robot: none loaded yet.",
            _cost_line,
        )
        self.picker = SweepPicker(server, self.panel)
        """The plots (the panel's and the clickable one in the 3D view) and the picked point."""
        self._cancelling = False
        """Cancel was asked for the sweep under way (which may not have started its run yet)."""
        self._changed_to = ""
        """The robot loaded while the running sweep ran (which cancelled it), or ""."""
        self._armed = False
        """Set by `start_preparing` once the studio has started: from then on every robot load
        prepares the workers (the studio's own start is not slowed by it)."""
        state.on_robot.connect(self._on_robot)

    # --- the engine ---------------------------------------------------------------------------

    def _engine_for(self, workers: int) -> Any:
        """The engine with `workers` workers: the current one, or a new local cluster (niced
        workers) replacing it."""
        from app.sweep_engine import SweepEngine

        with self._engine_lock:
            if self._closed:
                raise StudioError("the studio is closing")
            engine = self._engine
            if engine is not None and engine.n_workers == workers:
                return engine
            if engine is not None:
                engine.close()
            self._engine = None
            engine = SweepEngine(n_workers=workers)
            with contextlib.suppress(Exception):  # a platform without priorities: run as is
                for pid in engine.worker_pids().values():
                    os.setpriority(os.PRIO_PROCESS, pid, WORKER_NICENESS)
            self._engine = engine
            return engine

    def _on_robot(self, loaded: Any) -> None:
        """A robot loaded: sweep it. The panel's choices start again for it; a running sweep
        (of the robot before) is cancelled."""
        from app.core.collocation.defaults import default_settings
        from app.core.collocation.settings import GaitSettings

        robot = loaded.robot
        self._robot = sweep_robot_of(robot.source)
        self._feet = (robot.foot("left").link, robot.foot("right").link)
        try:
            self._defaults = default_settings(robot)
            shown = self._defaults
        except StudioError as error:  # the planner cannot walk it: said again by Run
            self._defaults, shown = error, GaitSettings()
        if self._thread is not None and self._thread.is_alive():
            self._changed_to = robot.name
            self.cancel()
        self.picker.place(robot)
        choices = _choices(self._robot, shown)
        self.panel.offer(_ordered(choices), choices, _robot_line(self._robot, robot.name))
        self.on_choices.emit(self._robot)
        if self._armed:
            self.prepare_workers()

    def _spec_data(self, values: dict[str, Any]) -> dict[str, Any]:
        """The sweep data of the loaded robot with the panel's `values`: a .urdf robot's
        workers load it as the studio did (its package folders, its feet)."""
        data: dict[str, Any] = {"robot": self._robot}
        if self._robot not in BUILTIN_ROBOTS and self._feet is not None:
            data |= {"package_roots": list(self._package_roots), "feet": list(self._feet)}
        return {**data, **values}

    def _planner_defaults(self) -> Any:
        """The loaded robot's planner defaults, or StudioError why the planner cannot walk it."""
        if isinstance(self._defaults, StudioError):
            raise StudioError(f"{self._robot}: the planner cannot walk it: {self._defaults}")
        if self._defaults is None:
            raise StudioError("no robot loaded yet")
        return self._defaults

    def start_preparing(self) -> None:
        """The studio has started: with `prepare`, prepare the workers for the loaded robot
        now and for every robot loaded later."""
        if self._prepare and not self._armed:
            self._armed = True
            self.prepare_workers()

    def prepare_workers(self) -> None:
        """Start the cluster and build the swept robot's NLP (at the panel's knots) and its
        anchor gait on every worker, on the low-priority thread "sweep-prepare". One preparer
        at a time: robots loaded while it works (50 project opens in a row) are folded into
        one more round, for the robot loaded last."""
        with self._prepare_lock:
            self._prepare_wanted = True
            if self._preparer is not None:
                return  # the running preparer goes round once more, for the latest robot
            self._preparer = threading.Thread(
                target=self._prepare_rounds, name="sweep-prepare", daemon=True
            )
            self._preparer.start()

    def _prepare_rounds(self) -> None:
        with contextlib.suppress(Exception):  # this thread only: the studio keeps its priority
            os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), WORKER_NICENESS)
        while True:
            with self._prepare_lock:
                if not self._prepare_wanted or self._closed:
                    self._preparer = None
                    return
                self._prepare_wanted = False
            self._prepare_now()

    def _prepare_now(self) -> None:
        try:
            if self._thread is not None and self._thread.is_alive():
                return  # a sweep is running: its points build what they need
            robot, defaults = self._robot, self._planner_defaults()
            data = self._spec_data(self.panel.spec_values())
            try:
                spec = SweepSpec.from_mapping(data, "sweep panel")
            except StudioError:  # the panel holds a bad sweep: prepare its knots anyway
                knots = dict(data.get("gait", {})).get("knots", 14)
                spec = SweepSpec.from_mapping(
                    self._spec_data(
                        {
                            "gait": {"knots": knots},
                            "parameter": [{"name": "H_s", "min": 0.7, "max": 0.7}],
                        }
                    )
                )
            point = start_point(spec, defaults)
            engine = self._engine_for(_whole(self.panel.workers.value, "workers"))
            self.prepared_s = engine.prepare(point)
        except CancelledError as error:  # the engine was replaced or closed meanwhile
            log.info("preparing the sweep workers was interrupted: %s", type(error).__name__)
            return
        except Exception:  # background work: the first sweep will build what it needs
            if not self._closed:
                log.exception("preparing the sweep workers failed")
            return
        if self.outcome is None and not (self._thread is not None and self._thread.is_alive()):
            self.panel.status.content = (
                f"No sweep yet; {len(self.prepared_s)} workers ready with {Path(robot).name}'s "
                f"{point.settings.knots}-knot gait problem built."
            )
        self.prepared.set()
        self.on_prepared.emit(self.prepared_s)

    # --- running ------------------------------------------------------------------------------

    def run(self, client: viser.ClientHandle | None = None) -> None:
        """Check the panel's sweep and start it; a bad one is refused with the reason."""
        with self._lock:
            if self._thread is not None and self._thread.is_alive():
                return
            try:
                data = self._spec_data(self.panel.spec_values())
                spec = SweepSpec.from_mapping(data, "sweep panel")
                workers = _whole(self.panel.workers.value, "workers")
                points = sweep_points(spec, self._planner_defaults())
            except StudioError as error:
                self.panel.status.content = f"⚠️ {error}"
                self._notifier.error("Cannot run this sweep", str(error), client)
                return
            self._cancelling, self._changed_to = False, ""
            self.picker.clear()
            self.panel.running(True)
            self.panel.status.content = f"Starting {len(points)} points on {workers} workers…"
            self._data = data
            self._thread = threading.Thread(
                target=self._sweep, args=(spec, points, workers, client), name="sweep-runner"
            )
            self._thread.start()

    def cancel(self) -> None:
        self._cancelling = True  # before reading the run: a run starting now sees it
        run = self._run
        if run is not None:
            run.cancel()

    def _sweep(self, spec: SweepSpec, points: list[SweepPoint], workers: int, client: Any) -> None:
        results: list[PointResult] = []
        error = ""
        cancelled = False
        start = time.perf_counter()
        try:
            engine = self._engine_for(workers)
            self._run = run = engine.start(points)
            if self._cancelling:  # cancelled while the engine started
                run.cancel()
            for result in run.results():
                results.append(result)
                self._progress(spec, results, len(points), time.perf_counter() - start)
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
            self._run = None
        front = tuple(pareto_indices(spec, results))
        self.points = {p.index: p for p in points}
        self.outcome = SweepOutcome(spec, tuple(results), front, cancelled, error)
        self.record = SweepRecord.of(self._data, results, cancelled) if results else None
        done = "cancelled" if cancelled else "done"
        if cancelled and self._changed_to:
            done += f" (the robot changed to {self._changed_to}; these points are {spec.robot}'s)"
        self._changed_to = ""
        counts = tally(results, len(points), spec.simulate, finished=True).line()
        line = f"Sweep {done}: {counts}; Pareto points: {list(front)}."
        if error:
            self.panel.status.content = f"⚠️ {error}  \n{line}"
        else:
            self.panel.status.content = f"{self.panel.status.content}  \n{line}"
        self.panel.running(False)
        self.picker.show(spec, results, final=True)
        if self.picker.selected is None:
            self.picker.pick_first(front, self.panel.point.value)
        self.on_sweep_done.emit(self.outcome)

    def _progress(
        self, spec: SweepSpec, results: list[PointResult], total: int, seconds: float
    ) -> None:
        counts = tally(results, total, spec.simulate)
        line = f"{counts.line()}, {counts.pending} to come; {len(results) / seconds:.2f} points/s"
        simulated = [r for r in results if r.solved and np.isfinite(r.fell)]
        if simulated:
            line += f" (simulation {np.mean([r.sim_s for r in simulated]):.1f} s/point)"
        self.panel.status.content = line
        with self._server.atomic():
            self.picker.show(spec, results)

    # --- loading a point ----------------------------------------------------------------------

    def select(self, index: int, client: viser.ClientHandle | None = None) -> None:
        """Pick point `index` (its number typed in the panel, or a click on the plot)."""
        self.picker.select(index, client)

    def view_plot(self, client: viser.ClientHandle | None = None) -> None:
        """Turn the tab's camera to the clickable Pareto plot in the 3D view."""
        self.picker.view(client)

    def load_point(self, client: viser.ClientHandle | None = None) -> None:
        """Load the chosen point's robot and play a walk of its gait, on "sweep-loader"."""
        outcome, engine = self.outcome, self._engine
        try:
            index = _whole(self.panel.point.value, "Point #")
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
            self.panel.status.content = f"⚠️ {error}"
            self._notifier.error("Cannot load this point", str(error), client)
            return
        point = self.points[index]
        threading.Thread(
            target=self._load, args=(engine, point, client), name="sweep-loader"
        ).start()

    def _load(self, engine: Any, point: SweepPoint, client: Any) -> None:
        from app.core.collocation.planar_model import PlanarModel
        from app.core.robot.loading import load_robot
        from app.core.robot.report import robot_report
        from app.core.walking.walk import build_walk

        try:
            if engine is None:  # a sweep restored from a project: start the workers now
                engine = self._engine_for(1)
            loaded = self._state.robot
            same = loaded is not None and sweep_robot_of(loaded.source) == point.robot.robot
            if point.robot.robot not in BUILTIN_ROBOTS and not same:  # a file: not read again
                raise StudioError(
                    f"point {point.index} is of {Path(point.robot.robot).name}: load that robot "
                    "first (Robot panel), then its points"
                )
            gait = engine.solve(point)
            if not gait.converged:
                raise StudioError(f"point {point.index} did not solve again: {gait.status}")
            if point.robot.values:  # a file that stays: the gait worker and saves read it
                robot = load_robot(point.robot.write_urdf(self._variants_dir))
            elif same:
                assert loaded is not None
                robot = loaded  # the robot swept is on screen: it stays (and the panel's choices)
            else:
                robot = point.robot.load()
            walk = build_walk(PlanarModel(robot), gait, steps=WALK_STEPS)
            report = robot_report(robot)
            changed = ", ".join(f"{n} = {v:.4g}" for n, v in point.robot.values) or "as built"
            summary = (
                f"**sweep point #{point.index}** — {robot.name} ({changed}), SR {gait.sr:.4f}, "
                f"max |τ| {gait.max_abs_tau_Nm:.2f} N·m; a walk of {WALK_STEPS} steps"
            )
            servos = None
            if point.simulation is not None:
                setup = point.simulation
                servos = servo_settings(robot, setup)
                summary += (
                    f"; servos {setup.compliance_deg_per_Nm:.3g} °/(N·m), dead band "
                    f"{setup.dead_band_deg:.3g}°, compensation {'on' if setup.compensation else 'off'}"
                )
            with self._state.lock, self._server.atomic():
                if robot is not loaded:
                    self._state.set_robot(robot, report)
                self._state.set_motion(walk.trajectory, summary, robot)
            if servos is not None and self._servos is not None:
                self._servos(*servos)  # after the robot: loading it reset the servos
            self._state.on_play.emit(None)
        except Exception as error:  # a thread boundary: bad input, or a worker lost meanwhile
            if not isinstance(error, StudioError):
                log.exception("loading a sweep point failed")
            self.panel.status.content = f"⚠️ {error}"
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
        elif spec.robot == self._robot:  # a URDF's sweep: the file is read only as loaded
            self.points = {p.index: p for p in sweep_points(spec, self._planner_defaults())}
        else:
            self.points = {}
        self.outcome = SweepOutcome(spec, results, front, record.cancelled)
        self.panel.show_spec(json.loads(record.spec_json))
        solved = [r for r in results if r.solved]
        counts = tally(results, spec.n_points, spec.simulate, finished=True).line()
        self.panel.status.content = (
            f"From the project{' (cancelled)' if record.cancelled else ''}: {counts}; "
            f"Pareto points: {list(front)}."
        )
        self.picker.show(spec, results, final=True)
        self.picker.pick_first(front, self.panel.point.value)
        if solved and not self.points:
            self.panel.load_button.disabled = True
            self.panel.status.content += (
                f"  \nLoad its points after loading {Path(spec.robot).name} (Robot panel)."
            )

    def close(self) -> None:
        self.cancel()
        thread = self._thread
        if thread is not None:
            thread.join(30.0)
        with self._engine_lock:  # waits for an engine being made, then no other is made
            self._closed = True
            engine, self._engine = self._engine, None
        if engine is not None:
            engine.close()


def _whole(value: float, what: str) -> int:
    if not np.isfinite(value) or not float(value).is_integer() or value < 0:
        raise StudioError(f"{what} = {value}: give a whole number")
    return int(value)
