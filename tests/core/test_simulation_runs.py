"""Runs side by side, the files around them, and the paper's experiment table."""

from __future__ import annotations

import numpy as np
import pytest

from app.core.servo.model import joint_angles
from app.core.simulation.errors import SimulationInputError
from app.core.simulation.experiments import PAPER_EXPERIMENTS, compensations
from app.core.simulation.files import default_servos, read_servo_toml
from app.core.simulation.run import simulate_commands


def test_runs_in_worker_processes_equal_runs_in_this_one(servo_biped, com_shift):
    """The step loop is deterministic and its inputs pickle: two spawned workers give the
    sequential results bit for bit; progress reaches 1."""
    q_plan = joint_angles(servo_biped, com_shift.q)
    lower = [joint.lower for joint in servo_biped.joints]
    upper = [joint.upper for joint in servo_biped.joints]
    commands = {"plan": q_plan, "shifted": np.clip(q_plan + np.deg2rad(1.0), lower, upper)}
    servo = default_servos(servo_biped)
    seen: list[float] = []
    here = simulate_commands(
        servo_biped, com_shift, commands, servo, parallel=False, progress=seen.append
    )
    there = simulate_commands(servo_biped, com_shift, commands, servo, parallel=True)
    for label in commands:
        np.testing.assert_array_equal(here[label].q, there[label].q)
        assert here[label].label == label
    assert not np.array_equal(here["plan"].q, here["shifted"].q)
    assert seen == sorted(seen) and seen[-1] == 1.0 and min(seen) < 0.5


def test_servo_toml_defaults_and_overrides(servo_biped, tmp_path):
    path = tmp_path / "servo.toml"
    path.write_text(
        "compliance_deg_per_Nm = 2.0\nbacklash_deg = 1.0\nlegs_only = false\n"
        "[joints.left_knee]\ncompliance_deg_per_Nm = 0.5\n"
    )
    servo = read_servo_toml(path, servo_biped)
    knee = servo_biped.joint_names.index("left_knee")
    assert servo.compliance_deg_per_Nm[knee] == 0.5 and servo.backlash_deg[knee] == 1.0
    others = np.delete(servo.compliance_deg_per_Nm, knee)
    assert np.all(others == 2.0)
    path.write_text("compliance_deg_per_Nm = 'soft'\n")
    with pytest.raises(SimulationInputError, match="finite number"):
        read_servo_toml(path, servo_biped)
    path.write_text("stiffness = 3\n")
    with pytest.raises(SimulationInputError, match="unknown key"):
        read_servo_toml(path, servo_biped)


def test_default_servos_are_on_the_legs(servo_biped):
    servo = default_servos(servo_biped)
    assert np.all(servo.compliance_deg_per_Nm == 1.4)  # servo_biped has legs only
    assert np.all(servo.backlash_deg == 0.5)


def test_the_compared_compensations_invert_the_servo_model(servo_biped):
    """eq 23 with the torque sign and φ = b/2 is the exact inverse of the quasi-static servo
    (q = q_cmd − c·τ − (b/2)·sign τ): applied to random torques it returns the plan."""
    from app.core.servo.compensation import compensated_command
    from app.core.servo.model import servo_response

    servo = default_servos(servo_biped)
    rng = np.random.default_rng(3)
    q = rng.uniform(-0.5, 0.5, (20, servo_biped.n_actuated))
    tau = rng.uniform(-3, 3, (20, servo_biped.n_actuated))
    params = compensations(servo)["eq 23, sign(τ)"]
    assert params is not None
    np.testing.assert_allclose(servo_response(compensated_command(q, tau, params), tau, servo), q)
    assert {e.paper_without for e in PAPER_EXPERIMENTS} == {"stays up", "falls"}


def test_the_studio_worker_runs_a_simulation_job(servo_biped, com_shift):
    """Through app.jobs.SolverWorker (a spawned process): progress arrives, and the finished
    results equal the same runs made here."""
    import threading

    from app.core.simulation.run import finish_job, simulation_job
    from app.core.simulation.worker import SIMULATION_KEY
    from app.jobs import SolverWorker

    q_plan = joint_angles(servo_biped, com_shift.q)
    servo = default_servos(servo_biped)
    job = simulation_job(servo_biped, com_shift, {"without": q_plan}, servo)
    ended = threading.Event()
    events: list[tuple] = []
    worker = SolverWorker("app.core.simulation.worker:build_simulation_problem")
    try:
        worker.on_progress(lambda job_id, percent, fraction, _: events.append(("p", fraction)))
        worker.on_done(lambda job_id, runs: (events.append(("done", runs)), ended.set()))
        worker.on_failed(lambda job_id, message: (events.append(("failed", message)), ended.set()))
        worker.submit("sim-1", job, SIMULATION_KEY)
        assert ended.wait(120.0), events
    finally:
        worker.close()
    assert events[-1][0] == "done", events[-1]
    fractions = [e[1] for e in events if e[0] == "p"]
    assert fractions and fractions[-1] == 1.0
    results = finish_job(servo_biped, com_shift, job, events[-1][1])
    here = simulate_commands(servo_biped, com_shift, {"without": q_plan}, servo, parallel=False)
    np.testing.assert_array_equal(results["without"].q, here["without"].q)
    assert results["without"].verdict() == here["without"].verdict()
