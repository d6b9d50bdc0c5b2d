"""Bench entry of the replay: a 10 s motion with four ghosts exported (scene, recording,
folder) in ≤ 5 s and ≤ 20 MB, against a baseline measured in the same run: the same frames
shown back to back on a live scene (a viser server, no recording)."""

from __future__ import annotations

import contextlib
import sys
import tempfile
from pathlib import Path

import numpy as np

from app.bench.registry import BenchContext, bench_entry
from app.bench.report import Figure
from app.bench.timing import PROCESS_CPU, stopwatch
from app.core.dynamics.wbc import torque_feedforward
from app.core.motions.library import run_motion
from app.core.replay.pipeline import prediction_verdicts
from app.core.replay.scene import PREDICTED_GHOSTS, replay_scene, title_card
from app.core.robot.loading import load_robot
from app.core.servo.model import predict
from app.core.servo.presets import preset_params
from app.core.simulation.files import default_servos
from app.replay_recorder import draw_scene, export_replay, private_server

REPLAY_TARGET_S = 5.0
REPLAY_TARGET_MB = 20.0
MOTION_S = 10.0


@bench_entry("replay")
def _entry_replay(ctx: BenchContext) -> tuple[dict, list[Figure]]:
    row = bench_replay()
    return row, [
        Figure(
            f"replay export, {row['robot']} {row['motion_s']:.1f} s with {row['ghosts']} ghosts "
            f"({row['total_mb']:.1f} MB, target ≤ {REPLAY_TARGET_MB:.0f} MB)",
            row["export_s"],
            "s",
            f"≤ {REPLAY_TARGET_S:.0f} s",
            row["export_s"] <= REPLAY_TARGET_S and row["total_mb"] <= REPLAY_TARGET_MB,
            row["baseline_playback_s"],
            "the same frames shown on a live scene",
            f"CPU {row['export_cpu_s']:.1f} s vs {row['baseline_playback_cpu_s']:.1f} s",
        )
    ]


def bench_replay(robot_name: str = "servo_biped") -> dict:
    robot = load_robot(robot_name)
    natural = run_motion(robot, "one_leg_squats").trajectory.duration
    trajectory = run_motion(robot, "one_leg_squats", speed=natural / MOTION_S).trajectory
    feedforward = torque_feedforward(robot, trajectory)
    prediction = predict(
        robot,
        trajectory,
        np.nan_to_num(feedforward.tau_Nm),
        preset_params("uniform", robot),
        default_servos(robot),
    )
    title = title_card(
        robot.name, trajectory.name, trajectory.duration, {}, prediction_verdicts(prediction)
    )
    with tempfile.TemporaryDirectory() as folder:
        with stopwatch(PROCESS_CPU) as export:
            scene = replay_scene(robot, trajectory, title, prediction, ghosts=PREDICTED_GHOSTS)
            result = export_replay(robot, scene, Path(folder) / "replay")
        export_s, export_cpu_s = export.wall_s, export.cpu_s
        total_mb = result.folder.total_bytes / 1e6
        recording_mb = result.folder.recording_bytes / 1e6
    server = private_server()
    try:
        with stopwatch(PROCESS_CPU) as playback, server.atomic():
            draw_scene(server, robot, scene, None)
        playback_s, playback_cpu_s = playback.wall_s, playback.cpu_s
    finally:
        with contextlib.redirect_stdout(sys.stderr):
            server.stop()
    return {
        "robot": robot.name,
        "motion_s": trajectory.duration,
        "frames": scene.n_frames,
        "ghosts": len(scene.ghosts),
        "export_s": export_s,
        "total_mb": total_mb,
        "recording_mb": recording_mb,
        "baseline_playback_s": playback_s,
        "ratio": export_s / playback_s,
        "export_cpu_s": export_cpu_s,
        "baseline_playback_cpu_s": playback_cpu_s,
        "cpu_ratio": export_cpu_s / playback_cpu_s,
    }
