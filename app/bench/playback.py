"""Bench entries of playback: scene pushes while a motion plays.

- playback: scene pushes per second while showing a trajectory's samples back to back
  (robot, overlays, timeline); target ≥ 60 Hz.
- playback_ghosts: the same on Roban S14 with the four ghosts (planned, command, without, with)
  and the traces, CPU per push, beside the same pushes with the ghosts drawn one scene node per
  link (a RobotView each, as before the batched ghosts); target ≥ 60 Hz.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from app.bench.registry import BenchContext, bench_entry, motion_with_torques
from app.bench.report import Figure
from app.bench.timing import WALL, stopwatch, timed_each
from app.studio import Studio
from panels.quiet import set_value

PLAYBACK_TARGET_HZ = 60.0


@bench_entry("playback")
def _entry_playback(ctx: BenchContext) -> tuple[dict, list[Figure]]:
    row = _bench_playback(ctx.studio, "servo_biped")
    period_ms = 1000.0 / row["pushes_per_s"]
    return row, [
        Figure(
            "playback scene push, servo_biped with overlays and traces",
            period_ms,
            "ms",
            f"≥ {PLAYBACK_TARGET_HZ:.0f} Hz (≤ {1000.0 / PLAYBACK_TARGET_HZ:.1f} ms)",
            row["pushes_per_s"] >= PLAYBACK_TARGET_HZ,
            row["bare_fk_ms"],
            "pinocchio's bare forward kinematics + link placements of the same samples",
            f"{row['pushes_per_s']:.0f} Hz",
        )
    ]


@bench_entry("playback_ghosts")
def _entry_playback_ghosts(ctx: BenchContext) -> tuple[dict, list[Figure]]:
    if ctx.roban is None:
        return {}, []
    row = _bench_playback_ghosts(ctx.studio, ctx.roban)
    return row, [
        Figure(
            "playback scene push, Roban S14 with four ghosts and traces (CPU)",
            row["cpu_ms"],
            "ms",
            f"≥ {PLAYBACK_TARGET_HZ:.0f} Hz (≤ {1000.0 / PLAYBACK_TARGET_HZ:.1f} ms)",
            row["cpu_ms"] <= 1000.0 / PLAYBACK_TARGET_HZ,
            row["per_node_cpu_ms"],
            "the same pushes, ghosts drawn one scene node per link",
            f"{1000.0 / row['cpu_ms']:.0f} Hz of CPU; wall {row['wall_hz']:.0f} Hz",
        )
    ]


def _bench_playback(studio: Studio, robot: str, seconds: float = 2.0) -> dict:
    from app.core.motions.trajectory import from_configurations

    studio.robots.load(robot)
    assert studio.state.robot is not None
    model, q0 = studio.state.robot, studio.state.robot.q_neutral
    qs = []
    for t in np.arange(0.0, 4.0, 0.01):
        angles = model.joint_angles(q0) + 0.2 * np.sin(2.0 * np.pi * t)
        qs.append(
            model.with_joint_angles(
                q0,
                np.clip(angles, [j.lower for j in model.joints], [j.upper for j in model.joints]),
            )
        )
    trajectory = from_configurations(
        model.model, "bench", model.joint_names, 0.01, np.array(qs), np.ones((len(qs), 2), bool)
    )
    studio.state.set_motion(trajectory, "bench", model)
    count, begin = 0, WALL()
    while WALL() - begin < seconds:  # as many pushes as fit in `seconds`
        with studio.state.lock, studio.web.server.atomic():
            studio.state.set_time((count * 0.01) % trajectory.duration)
        count += 1
    pushes_per_s = count / (WALL() - begin)
    data = model.model.createData()
    samples = [trajectory.q[k % trajectory.n_samples] for k in range(count)]
    bare = timed_each(lambda q: model.link_placements(q, data), samples)
    return {"pushes": count, "pushes_per_s": pushes_per_s, "bare_fk_ms": 1e3 * float(np.mean(bare))}


def _bench_playback_ghosts(studio: Studio, roban: Path, frames: int = 120) -> dict:
    """Roban S14's one-leg stand with its torques: the timeline stepped sample by sample with
    the four ghosts shown and the traces on; then the same steps with the ghosts hidden and
    four per-node RobotViews placed at the ghosts' poses instead (the path before batching)."""
    from app.views.robot_view import RobotView

    motion_with_torques(studio, str(roban), "one_leg_stand")
    session, trajectory = studio.servo_rooms.ghosts, studio.state.trajectory
    assert trajectory is not None and session.view is not None
    shown = ("planned", "command", "without", "with")
    for name in shown:
        set_value(session.panel.ghosts[name], True)
    set_value(studio.playback.panel.traces, True)

    def push(count: int) -> None:
        with studio.state.lock, studio.web.server.atomic():
            studio.state.set_time(float(trajectory.t[count % trajectory.n_samples]))

    with stopwatch() as batched:
        for count in range(frames):
            push(count)
    for name in shown:
        set_value(session.panel.ghosts[name], False)
    robot = studio.state.robot
    assert robot is not None and studio.state.work.prediction is not None
    views = [
        RobotView(studio.web.server, robot, root=f"/bench_ghosts/{name}", with_collision=False)
        for name in shown
    ]
    prediction = studio.state.work.prediction
    with stopwatch() as per_node:
        for count in range(frames):
            k = count % trajectory.n_samples
            push(count)
            with studio.web.server.atomic():
                for view, q in zip(
                    views,
                    (
                        trajectory.q[k],
                        prediction.q_world_compensated[k],  # stands in for the command ghost
                        prediction.q_world_uncompensated[k],
                        prediction.q_world_compensated[k],
                    ),
                    strict=True,
                ):
                    view.update(q)
    for view in views:
        view.remove()
    return {
        "frames": frames,
        "cpu_ms": batched.cpu_s / frames * 1000.0,
        "wall_hz": frames / batched.wall_s,
        "per_node_cpu_ms": per_node.cpu_s / frames * 1000.0,
    }
