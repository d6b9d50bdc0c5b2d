"""`biped-studio bench`: the studio's speed targets, measured on fixed work, server side.

- load: time from "load this URDF" to its scene being queued for the browser (parse, meshes,
  pinocchio model, scene nodes, panels), median of several loads; target ≤ 2 s for Roban S14.
- slider: time from a joint slider's new value to the scene update being queued (forward
  kinematics + node updates), p50 / p95 over many changes; target ≤ 5 ms.
- drag: time from a foot gizmo's new pose to the scene update being queued (whole-body IK to
  convergence, overlays, sliders), p50 / p95 over a circle of targets; target p95 ≤ 5 ms.
- playback: scene pushes per second while showing a trajectory's samples back to back
  (robot, overlays, timeline); target ≥ 60 Hz.
- interpolate: a keyframed motion (the three one-leg squats) sampled at 100 Hz with IK at
  every sample, scaled to 10 s of motion; target ≤ 1 s.
- feedforward: the whole-body QP per sample (median, p95) and for 10 s of motion at 100 Hz
  (app.core.dynamics.wbc_bench); targets ≤ 0.5 ms median, ≤ 0.5 s.
- compensation slider: a k slider moved with a 10 s motion loaded: re-prediction, ghosts and
  plots (τ not recomputed); target ≤ 50 ms.
- plan: the gait paper's case (38 knots) built and solved cold, target ≤ 10 s (the paper:
  65 s – 5 min with SNOPT); a warm re-solve after one slider change, target ≤ 1 s; the same on
  servo_biped with its scaled defaults, and a 10-step walk of the cycle to torques, ≤ 5 s.
- simulate: servo_biped's one-leg squats on MuJoCo with the default virtual servos (≥ 10× real
  time; the same steps of bare MuJoCo beside it), Roban S14's (≥ 5×), and the studio's
  Simulate click to the verdict, ghosts and plots (≤ 2 s), with the worker already started.
"""

from __future__ import annotations

import argparse
import json
import socket
import statistics
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from app.config import StudioConfig
from app.core.dynamics.wbc_bench import bench_feedforward
from app.core.simulation.bench import bench_simulation
from app.studio import Studio
from panels.quiet import set_value

ROBAN_CANDIDATES = (
    Path(__file__).resolve().parents[1]
    / "tests"
    / "third_party"
    / "roban_s14"
    / "urdf"
    / "robanS14.urdf",
)
LOAD_TARGET_S = 2.0
SLIDER_TARGET_MS = 5.0
DRAG_TARGET_MS = 5.0
PLAYBACK_TARGET_HZ = 60.0
INTERPOLATE_TARGET_S = 1.0
COMPENSATION_TARGET_MS = 50.0
PLAN_COLD_TARGET_S = 10.0
PLAN_WARM_TARGET_S = 1.0
WALK_TARGET_S = 5.0
SIMULATE_CLICK_TARGET_S = 2.0


def run_bench(args: argparse.Namespace) -> int:
    robot = args.robot or next((str(p) for p in ROBAN_CANDIDATES if p.exists()), "servo_biped")
    with tempfile.TemporaryDirectory() as data_dir:
        studio = Studio(StudioConfig(port=_free_port(), data_dir=Path(data_dir)))
        try:
            results = {
                "load": _bench_load(studio, robot),
                "slider": {
                    "servo_biped": _bench_slider(studio, "servo_biped", args.repeats),
                    Path(robot).stem: _bench_slider(studio, robot, args.repeats),
                },
                "drag": {
                    "servo_biped": _bench_drag(studio, "servo_biped", args.repeats),
                    Path(robot).stem: _bench_drag(studio, robot, args.repeats),
                },
                "playback": _bench_playback(studio, "servo_biped"),
                "interpolate": _bench_interpolate(studio),
                "feedforward": bench_feedforward(
                    next((p for p in ROBAN_CANDIDATES if p.exists()), None)
                ),
                "compensation_slider": _bench_compensation_slider(studio),
                "plan": _bench_plan(),
                "plan_servo_biped": _bench_plan_robot("servo_biped"),
                "simulate": bench_simulation(
                    next((str(p) for p in ROBAN_CANDIDATES if p.exists()), None)
                ),
                "simulate_click": _bench_simulate_click(studio),
            }
        finally:
            studio.stop()
    if getattr(args, "sweep", False):
        from app.sweep_bench import bench_sweep

        results["sweep"] = bench_sweep()
    if args.json:
        print(json.dumps(results, indent=2))
        return 0
    load = results["load"]
    print(
        f"load {load['robot']}: median {load['median_s']:.3f} s over {load['runs']} loads "
        f"(target ≤ {LOAD_TARGET_S} s) {_mark(load['median_s'] <= LOAD_TARGET_S)}"
    )
    for name, row in results["slider"].items():
        print(
            f"slider → scene, {name}: p50 {row['p50_ms']:.2f} ms, p95 {row['p95_ms']:.2f} ms over "
            f"{row['changes']} changes (target p95 ≤ {SLIDER_TARGET_MS} ms) {_mark(row['p95_ms'] <= SLIDER_TARGET_MS)}"
        )
    for name, row in results["drag"].items():
        print(
            f"foot drag → IK → scene, {name}: p50 {row['p50_ms']:.2f} ms, p95 {row['p95_ms']:.2f} ms over "
            f"{row['events']} events (target p95 ≤ {DRAG_TARGET_MS} ms) {_mark(row['p95_ms'] <= DRAG_TARGET_MS)}"
        )
    rate = results["playback"]["pushes_per_s"]
    print(
        f"playback, servo_biped with overlays and traces: {rate:.0f} scene pushes/s "
        f"(target ≥ {PLAYBACK_TARGET_HZ} Hz) {_mark(rate >= PLAYBACK_TARGET_HZ)}"
    )
    row = results["interpolate"]
    print(
        f"keyframes → trajectory, servo_biped {row['motion']}: {row['seconds']:.2f} s for {row['duration_s']:.1f} s "
        f"of motion at 100 Hz with IK at every sample, {row['per_10s_s']:.2f} s per 10 s "
        f"(target ≤ {INTERPOLATE_TARGET_S} s) {_mark(row['per_10s_s'] <= INTERPOLATE_TARGET_S)}"
    )
    ff = results["feedforward"]
    for key in ("servo_biped", "roban_s14"):
        row = ff.get(key)
        if row:
            print(
                f"torque feed-forward QP per sample, {row['robot']} {row['motion']}: median "
                f"{row['qp_median_ms']:.2f} ms, p95 {row['qp_p95_ms']:.2f} ms "
                f"(target median ≤ 0.5 ms) {_mark(row['qp_median_ms'] <= 0.5)}"
            )
    row = ff["servo_biped"]
    print(
        f"torque feed-forward of 10 s at 100 Hz, servo_biped: {row['per_10s_s']:.2f} s "
        f"(target ≤ 0.5 s) {_mark(row['per_10s_s'] <= 0.5)}"
    )
    row = results["compensation_slider"]
    print(
        f"compensation slider → prediction, ghosts and plots, {row['samples']} samples: p50 "
        f"{row['p50_ms']:.1f} ms, p95 {row['p95_ms']:.1f} ms (target ≤ {COMPENSATION_TARGET_MS:.0f} ms) "
        f"{_mark(row['p95_ms'] <= COMPENSATION_TARGET_MS)}"
    )
    row = results["plan"]
    print(
        f"gait plan, the paper's case (38 knots + 2 virtual): cold {row['cold_s']:.2f} s "
        f"(build {row['build_s']:.2f} s + solve {row['cold_solve_s']:.2f} s, {row['cold_iterations']} IPOPT "
        f"iterations; target ≤ {PLAN_COLD_TARGET_S:.0f} s) {_mark(row['cold_s'] <= PLAN_COLD_TARGET_S)}; "
        f"warm re-solve after one slider {row['warm_s']:.2f} s, {row['warm_iterations']} iterations "
        f"(target ≤ {PLAN_WARM_TARGET_S:.0f} s) {_mark(row['warm_s'] <= PLAN_WARM_TARGET_S)}"
    )
    row = results["plan_servo_biped"]
    print(
        f"gait plan on servo_biped (its scaled defaults): cold {row['cold_s']:.2f} s "
        f"(target ≤ {PLAN_COLD_TARGET_S:.0f} s) {_mark(row['cold_s'] <= PLAN_COLD_TARGET_S)}; warm "
        f"{row['warm_s']:.2f} s (target ≤ {PLAN_WARM_TARGET_S:.0f} s) "
        f"{_mark(row['warm_s'] <= PLAN_WARM_TARGET_S)}; 10-step walk → torques {row['walk_to_torques_s']:.2f} s "
        f"(target ≤ {WALK_TARGET_S:.0f} s, QP follows {100 * row['qp_follow_rate']:.0f} % of the samples) "
        f"{_mark(row['walk_to_torques_s'] <= WALK_TARGET_S)}"
    )
    sim = results["simulate"]
    for key, target in (("servo_biped", 10.0), ("roban_s14", 5.0)):
        if f"{key}_wall_s" in sim:
            print(
                f"simulate {key} one-leg squats ({sim[f'{key}_motion_s']:.1f} s): {sim[f'{key}_wall_s']:.2f} s, "
                f"{sim[f'{key}_real_time_factor']:.0f}× real time (bare MuJoCo, same steps: "
                f"{sim[f'{key}_physics_only_s']:.2f} s; target ≥ {target:.0f}×) "
                f"{_mark(sim[f'{key}_real_time_factor'] >= target)}"
            )
    row = results["simulate_click"]
    print(
        f"Simulate click → verdict, ghosts, plots, servo_biped {row['motion_s']:.1f} s motion: "
        f"{row['seconds']:.2f} s (target ≤ {SIMULATE_CLICK_TARGET_S:.0f} s) "
        f"{_mark(row['seconds'] <= SIMULATE_CLICK_TARGET_S)}"
    )
    if "sweep" in results:
        from app.sweep_bench import sweep_lines

        for line in sweep_lines(results["sweep"], _mark):
            print(line)
    return 0


def _bench_plan_robot(name: str) -> dict:
    """A robot's own cycle (scaled defaults) cold, warm after K0 changes, and 10 steps of it
    walked and sent through the torque feed-forward."""
    import dataclasses

    from app.core.collocation.defaults import robot_gait_defaults
    from app.core.collocation.gait_problem import GaitProblem
    from app.core.collocation.planar_model import PlanarModel
    from app.core.dynamics.wbc import torque_feedforward
    from app.core.robot.loading import load_robot
    from app.core.walking.walk import build_walk

    robot = load_robot(name)
    planar = PlanarModel(robot)
    settings = robot_gait_defaults(planar).settings
    begin = time.perf_counter()
    problem = GaitProblem(planar, settings.knots, settings.baseline)
    cold = problem.solve(settings)
    cold_s = time.perf_counter() - begin
    begin = time.perf_counter()
    problem.solve(dataclasses.replace(settings, K0=0.9 * settings.K0), warm_start=cold)
    warm_s = time.perf_counter() - begin
    begin = time.perf_counter()
    walk = build_walk(planar, cold, steps=10)
    feedforward = torque_feedforward(robot, walk.trajectory)
    walk_s = time.perf_counter() - begin
    follow = 1.0 - len(feedforward.infeasible_samples) / walk.trajectory.n_samples
    return {
        "robot": name,
        "cold_s": cold_s,
        "cold_status": cold.status,
        "warm_s": warm_s,
        "walk_to_torques_s": walk_s,
        "walk_samples": walk.trajectory.n_samples,
        "qp_follow_rate": follow,
    }


def _bench_simulate_click(studio: Studio) -> dict:
    """The Simulate button on servo_biped's one-leg squats, torques computed and the worker
    started: from the click to the verdict, ghosts and plots shown."""
    studio.robots.load("servo_biped")
    set_value(studio.motions.panel.motion, "one_leg_squats")
    set_value(studio.motions.panel.generate, True)
    _compute_torques(studio)
    session = studio.compensation
    done = threading.Event()
    disconnect = session.runner.finished.connect(lambda _simulation: done.set())
    begin = time.perf_counter()
    session.simulate()
    done.wait()
    first_s = time.perf_counter() - begin
    done.clear()
    set_value(session.panel.k, float(session.panel.k.value) + 0.1)  # the simulation is now stale
    begin = time.perf_counter()
    session.simulate()
    done.wait()
    seconds = time.perf_counter() - begin
    disconnect()
    assert studio.state.trajectory is not None
    return {
        "motion_s": studio.state.trajectory.duration,
        "seconds": seconds,
        "first_click_s": first_s,
    }


def _bench_plan() -> dict:
    """The paper's case built and solved cold, then re-solved warm after K0 changes."""
    import dataclasses

    from app.core.collocation.dircon import GaitProblem, GaitSettings

    begin = time.perf_counter()
    problem = GaitProblem()
    build_s = time.perf_counter() - begin
    settings = GaitSettings()
    cold = problem.solve(settings)
    cold_s = time.perf_counter() - begin
    begin = time.perf_counter()
    warm = problem.solve(dataclasses.replace(settings, K0=5.0), warm_start=cold)
    warm_s = time.perf_counter() - begin
    return {
        "build_s": build_s,
        "cold_solve_s": cold.solve_s,
        "cold_s": cold_s,
        "cold_iterations": cold.iterations,
        "cold_status": cold.status,
        "warm_s": warm_s,
        "warm_iterations": warm.iterations,
        "warm_status": warm.status,
        "max_abs_tau_Nm": cold.max_abs_tau_Nm,
        "sr": cold.sr,
    }


def _compute_torques(studio: Studio) -> None:
    """Compute the torques of the current motion and wait for them."""
    done = threading.Event()
    disconnect = studio.compensation.torques_done.connect(lambda _result: done.set())
    studio.compensation.compute_torques()
    done.wait()
    disconnect()


def _bench_compensation_slider(studio: Studio, repeats: int = 20) -> dict:
    """A k slider moved on a 10 s motion (1000 samples): re-prediction, ghosts and plots."""
    studio.robots.load("servo_biped")
    set_value(studio.motions.panel.motion, "one_leg_squats")
    set_value(studio.motions.panel.generate, True)
    _compute_torques(studio)
    panel = studio.compensation.panel
    assert studio.state.trajectory is not None
    times = []
    for k in range(repeats):
        begin = time.perf_counter()
        set_value(panel.k, 1.0 + (k % 2))
        times.append(time.perf_counter() - begin)
    ms = np.array(times) * 1000.0
    return {
        "samples": studio.state.trajectory.n_samples,
        "p50_ms": float(np.percentile(ms, 50)),
        "p95_ms": float(np.percentile(ms, 95)),
    }


def _bench_interpolate(studio: Studio) -> dict:
    from app.core.motions.keyframes import interpolate
    from app.core.motions.library import MOTIONS, resolve_params

    studio.robots.load("servo_biped")
    assert studio.state.robot is not None
    plan = MOTIONS["one_leg_squats"].build(
        studio.state.robot, **resolve_params("one_leg_squats", {})
    )
    begin = time.perf_counter()
    result = interpolate(studio.state.robot, plan.keyframes, dt=0.01)
    seconds = time.perf_counter() - begin
    duration = result.trajectory.duration
    return {
        "motion": "one_leg_squats",
        "duration_s": duration,
        "seconds": seconds,
        "per_10s_s": seconds * 10.0 / duration,
    }


def _bench_drag(studio: Studio, robot: str, repeats: int) -> dict:
    """Drag the left foot around a 3 cm circle, 2 cm up, one event per target."""
    studio.robots.load(robot)
    assert studio.state.robot is not None
    foot = studio.state.robot.feet[0].link
    start = studio.state.robot.link_placements(
        studio.state.q, studio.state.robot.model.createData()
    )[foot]
    times = []
    for k in range(repeats):
        angle = 2.0 * np.pi * k / 50.0
        target = start.copy()
        target[:3, 3] += [0.03 * np.cos(angle), 0.03 * np.sin(angle), 0.02 + 0.01 * np.sin(angle)]
        begin = time.perf_counter()
        studio.pose.request_drag("left", target)
        times.append(time.perf_counter() - begin)
    ms = np.array(times[5:]) * 1000.0  # the first events lift the foot from the ground
    return {
        "events": len(ms),
        "p50_ms": float(np.percentile(ms, 50)),
        "p95_ms": float(np.percentile(ms, 95)),
    }


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
    count, begin = 0, time.perf_counter()
    while time.perf_counter() - begin < seconds:
        with studio.state.lock, studio.server.atomic():
            studio.state.set_time((count * 0.01) % trajectory.duration)
        count += 1
    return {"pushes": count, "pushes_per_s": count / (time.perf_counter() - begin)}


def _bench_load(studio: Studio, robot: str, runs: int = 5) -> dict:
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        ok = studio.robots.load(robot)
        studio.server.flush()
        times.append(time.perf_counter() - start)
        if not ok:
            raise SystemExit(f"bench: cannot load {robot}: {studio.notifier.last_error}")
    return {"robot": robot, "runs": runs, "median_s": statistics.median(times), "max_s": max(times)}


def _bench_slider(studio: Studio, robot: str, repeats: int) -> dict:
    studio.robots.load(robot)
    panel = studio.joints.panel
    assert panel is not None and studio.state.robot is not None
    names = list(panel.sliders)
    times = []
    for k in range(repeats):
        slider = panel.sliders[names[k % len(names)]]
        target = slider.min + (slider.max - slider.min) * (0.25 if (k // len(names)) % 2 else 0.75)
        start = time.perf_counter()
        set_value(slider, round(target, 1))
        times.append(time.perf_counter() - start)
    ms = np.array(times) * 1000.0
    return {
        "changes": repeats,
        "p50_ms": float(np.percentile(ms, 50)),
        "p95_ms": float(np.percentile(ms, 95)),
    }


def _mark(ok: bool) -> str:
    return "ok" if ok else "OVER TARGET"


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])
