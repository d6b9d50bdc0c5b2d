"""Bench entry of the projects: save, read and open a realistic project; drags while autosaving.

- projects: servo_biped with a walk of ≥ 10 s, its torques and its gait saved to a .bstudio
  and read back (≤ 1 s each; the same arrays written and read with bare np.save / np.load as
  the same-run baseline, and the ratio), opened in the studio (robot, prediction, panels;
  ≤ 1 s); and foot drags at 20 Hz with that project loaded, autosave on vs held, in turns of
  6 s (longer than autosave's MAX_DELAY_S, so autosaves are written mid-drag): the figure is
  the ratio of the p95s, target ≤ AUTOSAVE_DRAG_RATIO (autosave never blocks a drag).
"""

from __future__ import annotations

import statistics
import tempfile
from pathlib import Path

import numpy as np

from app.bench.posing import WARM_UP_EVENTS, drag_target, left_foot_placement
from app.bench.registry import BenchContext, bench_entry
from app.bench.report import Figure
from app.bench.timing import percentiles_ms, timed, timed_each
from app.studio import Studio

PROJECT_TARGET_S = 1.0
AUTOSAVE_DRAG_RATIO = 1.2
"""Drag p95 with autosave on ≤ this × the same drags with autosave held (issue 13)."""


@bench_entry("projects")
def _entry_projects(ctx: BenchContext) -> tuple[dict, list[Figure]]:
    with tempfile.TemporaryDirectory() as data_dir:
        row = _bench_projects(ctx.studio, Path(data_dir))
    what = f"servo_biped {row['motion_s']:.1f} s walk + torques + gait, {row['megabytes']:.1f} MB"
    target = f"≤ {PROJECT_TARGET_S:.0f} s"
    return row, [
        Figure(
            f"project save ({what})",
            row["save_s"],
            "s",
            target,
            row["save_s"] <= PROJECT_TARGET_S,
            row["np_save_s"],
            "bare np.save of the same arrays",
        ),
        Figure(
            "project read",
            row["open_s"],
            "s",
            target,
            row["open_s"] <= PROJECT_TARGET_S,
            row["np_load_s"],
            "bare np.load of the same arrays",
        ),
        ctx.beside_reference(
            "project opened in the studio (robot, ghosts, panels)",
            row["studio_open_s"],
            "s",
            target,
            row["studio_open_s"] <= PROJECT_TARGET_S,
        ),
        Figure(
            "foot drag at 20 Hz with that project, autosave on (p95)",
            row["drag_autosave_p95_ms"],
            "ms",
            f"ratio ≤ {AUTOSAVE_DRAG_RATIO:g}",
            row["drag_autosave_p95_ms"] <= AUTOSAVE_DRAG_RATIO * row["drag_held_p95_ms"],
            row["drag_held_p95_ms"],
            "the same drags with autosave held",
            f"{row['autosaves']} autosaves written meanwhile",
        ),
    ]


def _bench_projects(studio: Studio, data_dir: Path, runs: int = 5) -> dict:
    """Save / open of a realistic project against bare np.save / np.load of its arrays, the
    studio's Open, and drags with autosave on and held."""
    import math

    from app.core.collocation.defaults import robot_gait_defaults
    from app.core.collocation.gait_problem import GaitProblem
    from app.core.collocation.planar_model import PlanarModel
    from app.core.dynamics.wbc import torque_feedforward
    from app.core.projects.codec import encode
    from app.core.projects.files import read_project, save_project
    from app.core.projects.project import Project
    from app.core.projects.robot_files import robot_source
    from app.core.robot.loading import load_robot
    from app.core.walking.walk import build_walk
    from app.studio.compensation_session import default_params

    robot = load_robot("servo_biped")
    planar = PlanarModel(robot)
    settings = robot_gait_defaults(planar).settings
    gait = GaitProblem(planar, settings.knots, settings.baseline).solve(settings)
    steps = max(2, math.ceil(10.0 / max(gait.duration_s, 1e-3)))
    walk = build_walk(planar, gait, steps=steps)
    while walk.trajectory.duration < 10.0 and steps < 200:  # standing at both ends adds time
        steps += 2
        walk = build_walk(planar, gait, steps=steps)
    feedforward = torque_feedforward(robot, walk.trajectory)
    params, servo = default_params(robot)
    project = Project(
        robot=robot_source(robot),
        q=walk.trajectory.q[0],
        motion=walk.trajectory,
        motion_summary="walk",
        feedforward=feedforward,
        compensation=params,
        servo=servo,
        gait_settings=settings,
        gait_symmetric=gait,
    )
    path = data_dir / "bench.bstudio"
    save_s: list[float] = []
    open_s: list[float] = []
    for _ in range(runs):  # in turns, as a user saves and opens
        save_s += timed(lambda: save_project(path, project), 1)
        open_s += timed(lambda: read_project(path), 1)
    blobs: dict = {}
    encode(project, "project", blobs)
    arrays = {name: a for name, a in blobs.items() if isinstance(a, np.ndarray)}
    folder = data_dir / "bench-npy"
    folder.mkdir(exist_ok=True)

    def np_save() -> None:
        for i, array in enumerate(arrays.values()):
            np.save(folder / f"{i}.npy", array, allow_pickle=False)

    def np_load() -> None:
        for i in range(len(arrays)):
            np.load(folder / f"{i}.npy", allow_pickle=False)

    np_save_s: list[float] = []
    np_load_s: list[float] = []
    for _ in range(runs):
        np_save_s += timed(np_save, 1)
        np_load_s += timed(np_load, 1)
    opened: list[bool] = []
    studio_s = timed(lambda: opened.append(studio.project.open(path, trusted=True)), 3)
    if not all(opened):
        raise SystemExit(f"bench: cannot open the project: {studio.project.last_error}")
    count = [0]
    disconnect = studio.project.autosave.written.connect(
        lambda _path: count.__setitem__(0, count[0] + 1)
    )
    held_s: list[float] = []
    on_s: list[float] = []
    for _ in range(2):  # in turns, so a change in the machine's load weighs on both alike
        held_s += _paced_drags(studio, autosave=False)
        on_s += _paced_drags(studio, autosave=True)
    disconnect()
    held, on = (percentiles_ms(s, points=(95,))["p95_ms"] for s in (held_s, on_s))
    return {
        "motion_s": walk.trajectory.duration,
        "megabytes": path.stat().st_size / 2**20,
        "save_s": statistics.median(save_s),
        "open_s": statistics.median(open_s),
        "studio_open_s": statistics.median(studio_s),
        "np_save_s": statistics.median(np_save_s),
        "np_load_s": statistics.median(np_load_s),
        "drag_held_p95_ms": held,
        "drag_autosave_p95_ms": on,
        "autosaves": count[0],
    }


def _paced_drags(studio: Studio, autosave: bool, events: int = 125) -> list[float]:
    """Times [s] of foot drags sent at 20 Hz (a browser's rate) around a 3 cm circle, for
    longer than autosave's MAX_DELAY_S (the first WARM_UP_EVENTS left out)."""
    studio.project.autosave.paused = not autosave
    start = left_foot_placement(studio)
    targets = [drag_target(start, k, 40) for k in range(events)]
    times = timed_each(
        lambda target: studio.pose.request_drag("left", target), targets, pause_s=0.05
    )
    studio.project.autosave.paused = False
    return times[WARM_UP_EVENTS:]
