"""The torque feed-forward over worker processes gives the serial run's answer.

The chunks are solved the same way wherever they run (cold first sample, warm along the
chunk), so the answers agree to round-off, not bit for bit: OpenBLAS's and Eigen's vectorised
sums run in an order that depends on the alignment of each array in memory (measured: moving
the same trajectory by 8 bytes changes τ by ~1e-9 N·m) and on their thread count (1 in the
workers). The tolerance below is 1e-9 of the largest torque, ten orders under the QP's."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from app.core.dynamics.parallel import (
    MIN_POOL_SAMPLES,
    RUNS_PER_WORKER,
    FeedForwardPool,
    chunk_runs,
    worth_a_pool,
)
from app.core.dynamics.wbc import CHUNK_SAMPLES, WbcParams, chunk_bounds, torque_feedforward
from app.core.motions.library import run_motion
from app.core.motions.trajectory import repeated
from app.core.robot.loading import load_robot
from tests.trajectory_slices import first_samples


@pytest.fixture(scope="module")
def pool():
    with FeedForwardPool(workers=2) as pool:
        yield pool


@pytest.fixture(scope="module")
def one_worker():
    with FeedForwardPool(workers=1) as pool:
        yield pool


def _same(a, b) -> None:
    for field in ("tau_Nm", "contact_forces_N", "qdd", "loop_forces_N"):
        x, y = getattr(a, field), getattr(b, field)
        assert x.shape == y.shape and np.all(np.isnan(x) == np.isnan(y)), field
        scale = max(1.0, float(np.nanmax(np.abs(x)))) if x.size else 1.0
        assert np.nanmax(np.abs(x - y), initial=0.0) <= 1e-9 * scale, field
    assert a.status == b.status
    assert a.notes == b.notes


def test_parallel_torques_equal_serial(pool, one_worker):
    robot = load_robot("servo_biped")
    trajectory = run_motion(robot, "one_leg_squats", dt=0.01).trajectory
    assert trajectory.n_samples > 3 * CHUNK_SAMPLES  # several chunks, both workers busy
    serial = torque_feedforward(robot, trajectory, pool=one_worker)
    seen = []
    parallel = torque_feedforward(robot, trajectory, pool=pool, progress=seen.append)
    _same(serial, parallel)
    assert seen[-1] == 1.0 and seen == sorted(seen)
    # Warm workers (their QPs already built) answer the same again.
    _same(serial, torque_feedforward(robot, trajectory, pool=pool))


def test_workers_keep_parameters_apart(pool, one_worker):
    """A second parameter set on the same robot is solved with its own QP in the workers."""
    robot = load_robot("servo_biped")
    trajectory = run_motion(robot, "one_leg_squats", dt=0.01).trajectory
    params = dataclasses.replace(WbcParams(), mu=0.3)
    serial = torque_feedforward(robot, trajectory, params, pool=one_worker)
    _same(serial, torque_feedforward(robot, trajectory, params, pool=pool))
    default = torque_feedforward(robot, trajectory, pool=pool)
    assert not np.array_equal(serial.contact_forces_N, default.contact_forces_N)


def test_in_process_run_agrees(pool):
    robot = load_robot("servo_biped")
    trajectory = run_motion(robot, "one_leg_squats", dt=0.01).trajectory
    _same(torque_feedforward(robot, trajectory), torque_feedforward(robot, trajectory, pool=pool))


def test_chunk_runs_cover_every_chunk_once_in_order():
    """Brute force over sizes: contiguous runs, in order, covering 0…n, as even as can be."""
    for workers in range(1, 5):
        for n in range(0, 40):
            runs = chunk_runs(n, workers)
            flat = [k for start, stop in runs for k in range(start, stop)]
            assert flat == list(range(n))
            assert all(stop > start for start, stop in runs)
            assert len(runs) == min(n, RUNS_PER_WORKER * workers)
            sizes = [stop - start for start, stop in runs]
            assert not sizes or max(sizes) - min(sizes) <= 1


def test_uneven_runs_equal_serial(pool):
    """9 chunks (the last one short) over 2 workers: runs of one and of two chunks; the
    in-process serial run gives the same torques, statuses and a progress that ends at 1."""
    robot = load_robot("servo_biped")
    trajectory = first_samples(run_motion(robot, "one_leg_squats", dt=0.01).trajectory, 831)
    n_chunks = len(chunk_bounds(trajectory.n_samples))
    assert n_chunks % pool.workers != 0
    assert {stop - start for start, stop in chunk_runs(n_chunks, pool.workers)} == {1, 2}
    seen: list[float] = []
    parallel = torque_feedforward(robot, trajectory, pool=pool, progress=seen.append)
    _same(torque_feedforward(robot, trajectory), parallel)
    assert seen == sorted(seen) and seen[-1] == 1.0 and len(parallel.status) == 831


def test_a_long_motion_over_the_pool_equals_serial(pool):
    """Past the threshold (the squats repeated): many chunks per task, the serial answer."""
    robot = load_robot("servo_biped")
    trajectory = repeated(run_motion(robot, "one_leg_squats", dt=0.01).trajectory, 3)
    assert worth_a_pool(trajectory.n_samples)
    serial = torque_feedforward(robot, trajectory)
    _same(serial, torque_feedforward(robot, trajectory, pool=pool))
    # The motion repeated: each repetition's torques are the single motion's (chunks that
    # straddle a seam are solved sample by sample too, so the seam changes nothing).
    single = torque_feedforward(robot, first_samples(trajectory, trajectory.n_samples // 3))
    n = single.tau_Nm.shape[0]
    scale = max(1.0, float(np.nanmax(np.abs(single.tau_Nm))))
    for k in range(3):
        assert np.nanmax(np.abs(serial.tau_Nm[k * n : (k + 1) * n] - single.tau_Nm)) <= 1e-6 * scale


def test_threshold():
    assert not worth_a_pool(MIN_POOL_SAMPLES - 1) and worth_a_pool(MIN_POOL_SAMPLES)
