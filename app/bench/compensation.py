"""Bench entries of the compensation: the k slider's re-prediction, and the plots' cursor.

- compensation_slider: a k slider moved with a 10 s motion loaded: re-prediction, ghosts and
  plots (τ not recomputed); target ≤ 50 ms.
- compensation_slider_long: the same k slider on the one-leg squats repeated to 6 000 and
  60 000 samples (τ tiled from the 10 s motion's), the slider's CPU time (p95 of 20 moves)
  beside the uncached path (`app.core.servo.model.predict`, pinocchio sample by sample) on the
  same motion; targets ≤ 50 ms and ≤ 100 ms (issue 28). Its two halves are timed alone too
  (CPU p50): the predictor's re-prediction and the ghosts' redraw (plots and poses).
- plot_cursor: the four plots' time cursor moved on that motion (it moves ≤ 4×/s during
  playback, off the player's thread), beside the same plots resent without a cursor; target
  ≤ 25 ms.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from app.bench.registry import BenchContext, bench_entry, motion_with_torques
from app.bench.report import Figure
from app.bench.timing import laps_each, percentiles_ms, stopwatch, timed_each
from app.core.dynamics.wbc import FeedForward
from app.core.motions.trajectory import Trajectory, repeated
from app.studio import Studio
from panels.quiet import set_value

COMPENSATION_TARGET_MS = 50.0
COMPENSATION_LONG_TARGETS_MS = {6000: 50.0, 60000: 100.0}
"""CPU p95 of the k slider per motion length (60 000 samples: issue 28, was 200 ms)."""
PLOT_CURSOR_TARGET_MS = 25.0


@bench_entry("compensation_slider")
def _entry_compensation_slider(ctx: BenchContext) -> tuple[dict, list[Figure]]:
    row = _bench_compensation_slider(ctx.studio)
    row["uncached_ms"] = _uncached_prediction_s(ctx.studio) * 1e3
    return row, [
        Figure.at_most(
            f"compensation slider → prediction, ghosts, plots ({row['samples']} samples, p95)",
            row["p95_ms"],
            "ms",
            COMPENSATION_TARGET_MS,
            row["uncached_ms"],
            "the uncached prediction alone of the same motion (pinocchio sample by sample)",
        )
    ]


def _uncached_prediction_s(studio: Studio) -> float:
    """Wall time [s] of `app.core.servo.model.predict` on the studio's motion and torques with
    the slider's coefficients: the prediction without the session's caches."""
    from app.core.servo.model import predict

    robot, trajectory = studio.state.robot, studio.state.trajectory
    feedforward, coefficients = studio.state.work.torques, studio.state.work.coefficients
    assert robot and trajectory and feedforward and coefficients
    tau = np.nan_to_num(feedforward.tau_Nm)
    (seconds,) = timed_each(
        lambda _: predict(robot, trajectory, tau, coefficients.params, coefficients.servo),
        range(1),
    )
    return seconds


@bench_entry("compensation_slider_long")
def _entry_compensation_slider_long(ctx: BenchContext) -> tuple[dict, list[Figure]]:
    rows, figures = {}, []
    _bench_compensation_slider(ctx.studio, repeats=1)  # the 10 s motion and its τ, once
    base, feedforward = ctx.studio.state.trajectory, ctx.studio.state.work.torques
    assert base is not None and feedforward is not None
    for samples, target_ms in COMPENSATION_LONG_TARGETS_MS.items():
        row = rows[str(samples)] = _bench_compensation_slider_long(
            ctx.studio, samples, base, feedforward
        )
        figures.append(
            Figure.at_most(
                f"compensation slider → prediction, ghosts, plots ({row['samples']} samples, "
                "CPU p95)",
                row["cpu_p95_ms"],
                "ms",
                target_ms,
                row["uncached_cpu_ms"],
                "the uncached prediction alone (pinocchio sample by sample), CPU",
                f"wall p50 {row['wall_p50_ms']:.0f} ms; alone, CPU p50: prediction "
                f"{row['predict_cpu_p50_ms']:.0f} ms, ghosts' redraw {row['redraw_cpu_p50_ms']:.0f} ms",
            )
        )
    return rows, figures


@bench_entry("plot_cursor")
def _entry_plot_cursor(ctx: BenchContext) -> tuple[dict, list[Figure]]:
    if (
        ctx.studio.servo_rooms.ghosts.plots.torques is None
    ):  # run alone: load the slider bench's motion
        _bench_compensation_slider(ctx.studio, repeats=1)
    row = _bench_plot_cursor(ctx.studio)
    return row, [
        Figure.at_most(
            f"plots' time cursor moved ({row['points']} points × {row['curves']} curves)",
            row["p95_ms"],
            "ms",
            PLOT_CURSOR_TARGET_MS,
            row["baseline_p95_ms"],
            "the same plots resent without a cursor",
            stat="p95",
        )
    ]


def _bench_compensation_slider(studio: Studio, repeats: int = 20) -> dict:
    """A k slider moved on a 10 s motion (1000 samples): re-prediction, ghosts and plots."""
    motion_with_torques(studio, "servo_biped", "one_leg_squats")
    panel = studio.servo_rooms.compensation.panel
    assert studio.state.trajectory is not None
    times = timed_each(lambda k: set_value(panel.k, 1.0 + (k % 2)), range(repeats))
    return {"samples": studio.state.trajectory.n_samples, **percentiles_ms(times)}


def _bench_compensation_slider_long(
    studio: Studio, samples: int, base: Trajectory, feedforward: FeedForward, repeats: int = 20
) -> dict:
    """The k slider on the one-leg squats (`base`, its torques `feedforward`, loaded once by
    the caller) repeated to about `samples` samples, its τ tiled from the 10 s motion's (the
    slider never recomputes τ, so tiling changes no work)."""
    from app.core.servo.model import predict

    session, robot = studio.servo_rooms.compensation, studio.state.robot
    assert robot is not None
    copies = max(1, round(samples / base.n_samples))
    trajectory = repeated(base, copies)
    n, t = trajectory.n_samples, trajectory.t

    def tiled(array: np.ndarray) -> np.ndarray:
        return np.tile(array, (copies,) + (1,) * (array.ndim - 1))

    long_feedforward = dataclasses.replace(
        feedforward,
        t=t,
        tau_Nm=tiled(feedforward.tau_Nm),
        contact_forces_N=tiled(feedforward.contact_forces_N),
        qdd=tiled(feedforward.qdd),
        loop_forces_N=tiled(feedforward.loop_forces_N),
        status=feedforward.status * copies,
        qp_time_s=tiled(feedforward.qp_time_s),
        solver_time_s=None,
    )
    studio.state.set_motion(trajectory, "bench", robot)
    studio.state.work.set_torques(long_feedforward, trajectory)  # τ as if computed for this motion
    panel = session.panel
    laps = laps_each(lambda k: set_value(panel.k, 1.0 + (k % 2)), range(repeats))
    assert studio.state.work.coefficients is not None
    params, servo = studio.state.work.coefficients.params, studio.state.work.coefficients.servo
    predictor = session.cached_predictor()
    ghosts = studio.servo_rooms.ghosts
    assert predictor is not None
    alone = [
        laps_each(lambda _: predictor.predict(params, servo), range(repeats // 2)),
        laps_each(lambda _: ghosts.redraw(), range(repeats // 2)),
    ]
    with stopwatch() as uncached:
        predict(robot, trajectory, np.nan_to_num(long_feedforward.tau_Nm), params, servo)
    return {
        "samples": n,
        **percentiles_ms([lap.cpu_s for lap in laps], "cpu_"),
        **percentiles_ms([lap.wall_s for lap in laps], "wall_", points=(50,)),
        **percentiles_ms([lap.cpu_s for lap in alone[0]], "predict_cpu_", points=(50,)),
        **percentiles_ms([lap.cpu_s for lap in alone[1]], "redraw_cpu_", points=(50,)),
        "uncached_cpu_ms": uncached.cpu_s * 1000.0,
    }


def _bench_plot_cursor(studio: Studio, repeats: int = 20) -> dict:
    """The plots' cursor moved across the motion the compensation slider bench left loaded,
    against the same data pushes without a cursor (what a data push cost before it)."""
    plots, trajectory = studio.servo_rooms.ghosts.plots, studio.state.trajectory
    assert trajectory is not None and plots.torques is not None

    moved = timed_each(plots.show_time, list(np.linspace(0.0, trajectory.duration, repeats)))
    baseline = timed_each(plots.show_time, [None] * repeats)
    return {
        "points": len(plots.torques.data[0]),
        "curves": sum(
            len(h.data) - 2  # neither the time axis nor the cursor
            for h in (plots.torques, plots.roll, plots.pitch, plots.offsets)
            if h
        ),
        **percentiles_ms(moved),
        **percentiles_ms(baseline, "baseline_"),
        "ratio": float(np.percentile(moved, 50) / np.percentile(baseline, 50)),
    }
