"""A real studio on a free local port, for the server-side tests, and waits on the events the
studio announces (no sleeps)."""

from __future__ import annotations

import math
import socket
import threading
from collections.abc import Callable
from pathlib import Path

import pytest

from app.config import StudioConfig
from app.studio import Studio

GUARD_S = 300.0
"""A wait that takes longer than this fails the test instead of hanging the suite."""


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def start_studio(data_dir: Path) -> Studio:
    """A studio on the default robot, serving on a free port of 127.0.0.1; *Open path* may
    also load from the folder holding `data_dir` (where tests write their files)."""
    return Studio(StudioConfig(port=free_port(), data_dir=data_dir, allow=(data_dir.parent,)))


@pytest.fixture
def studio(tmp_path):
    studio = start_studio(tmp_path / "data")
    yield studio
    studio.stop()


def wait_for_signal(signal, start: Callable[[], object], accept=lambda _value: True):
    """Connect to `signal`, call `start`, and return the first emitted value `accept`s."""
    got: list = []
    done = threading.Event()

    def receive(value) -> None:
        if not done.is_set() and accept(value):
            got.append(value)
            done.set()

    disconnect = signal.connect(receive)
    try:
        start()
        assert done.wait(GUARD_S), f"{signal.name} was not emitted"
    finally:
        disconnect()
    return got[0]


def compute_torques(studio: Studio):
    """Compute the torque feed-forward of the current motion from the panel; its result."""
    session = studio.servo_rooms.torques
    return wait_for_signal(session.done, lambda: setattr(session.panel.compute, "value", True))


def simulate(studio: Studio):
    """Press *Simulate without / with compensation* and wait for the runs; the simulation."""
    session = studio.servo_rooms.simulation
    return wait_for_signal(
        session.runner.finished, lambda: setattr(session.panel.simulate, "value", True)
    )


def one_click(studio: Studio):
    """Press the Gait panel's *Plan → walk → torques → simulate* and wait for its simulation."""
    return wait_for_signal(
        studio.servo_rooms.simulation.runner.finished,
        lambda: setattr(studio.gait.panel.all_stages, "value", True),
    )


def with_stand_torques(studio: Studio) -> Studio:
    """`studio` with the one-leg stand generated from the Motions panel and its torques."""
    studio.motions.panel.motion.value = "one_leg_stand"
    studio.motions.panel.generate.value = True
    compute_torques(studio)
    return studio


def solve_gait(studio: Studio, button: str = "solve"):
    """Press a gait panel button ("solve" or "baseline") and wait for that solve to end."""
    panel = studio.gait.panel
    return wait_for_signal(
        studio.gait.finished, lambda: setattr(getattr(panel, button), "value", True)
    )


def set_sweep(
    panel,
    a: tuple[str, float, float],
    b: tuple[str, float, float] | None = None,
    *,
    samples: int,
    knots: int = 14,
    workers: int = 1,
) -> None:
    """Set the Sweep panel as a user does, in its order: the first parameter and its range
    `a` = (name, min, max), the second `b` (None: "(none)"), the samples, the planner's knots
    and the workers."""
    panel.param_a.value = a[0]
    panel.min_a.value, panel.max_a.value = a[1], a[2]
    panel.param_b.value = "(none)" if b is None else b[0]
    if b is not None:
        panel.min_b.value, panel.max_b.value = b[1], b[2]
    panel.samples.value, panel.knots.value, panel.workers.value = samples, knots, workers


def run_sweep(studio: Studio):
    """Press the Sweep panel's *Run* and wait for the sweep to end; its outcome."""
    session = studio.sweep
    return wait_for_signal(
        session.on_sweep_done, lambda: setattr(session.panel.run_button, "value", True)
    )


def load_point(studio: Studio, index: int):
    """Pick sweep point `index` in the Sweep panel and press *Load point*; the index the
    session announces loaded."""
    session = studio.sweep
    session.panel.point.value = index
    return wait_for_signal(
        session.on_point_loaded, lambda: setattr(session.panel.load_button, "value", True)
    )


def same_metric(a: float, b: float) -> bool:
    """Two values of a sweep metric agree: both NaN (no gait, no simulation) or equal to 1e-6."""
    return (math.isnan(a) and math.isnan(b)) or a == pytest.approx(b, rel=1e-6, abs=1e-9)


def assert_points_match_core(results, data: dict, metrics: tuple[str, ...]) -> list:
    """The panel's sweep `results` are the points of the sweep `data` (written out by the test
    as a sweep file's mapping) sampled and evaluated one by one in this process through
    app.core, not through the panel: the same values, solve and simulation status, and
    `metrics`. The points, in index order, for the test's own checks."""
    from app.core.sweeps.evaluate import ProblemCache, evaluate_point
    from app.core.sweeps.sampling import sweep_points
    from app.core.sweeps.spec import SweepSpec

    by_panel = sorted(results, key=lambda r: r.index)
    points = sweep_points(SweepSpec.from_mapping(data))
    cache = ProblemCache()
    for point, result in zip(points, by_panel, strict=True):
        assert result.values == point.values
        here = evaluate_point(point, cache)
        assert result.solved == here.solved and result.status == here.status
        assert result.sim_status == here.sim_status
        for metric in metrics:
            assert same_metric(result.metric(metric), here.metric(metric)), metric
    return points
