"""The Simulation rows' SR on the ideal servo (app.studio.ideal_sr_text) on constructed runs,
against the closed form of a held robot: every joint of servo_biped held still 1° short of
its command on its 1.4 °/(N·m) servos with a 0.5° dead band draws τ = K·(1° − 0.25°) through
the default motor (the catalogue's MX-64 geared to 6 N·m), E = Σ (τ/kt)²·R·T, while its root
is carried 0.5 m (SR = E / (M·g·d)); a run on servo parts and a motion in place get no line.
"""

from __future__ import annotations

import math
import re
from types import SimpleNamespace

import numpy as np
import pinocchio as pin
import pytest

from app.core.robot.loading import load_robot
from app.core.servo.catalogue import load_catalogue
from app.core.simulation.files import sized_servos
from app.core.simulation.worker import SimulationJob
from app.studio.ideal_sr_text import IdealSRText, ideal_sr_lines
from app.studio.simulation_runner import Simulation

T, DT, TRAVEL_M = 101, 0.01, 0.5


@pytest.fixture(scope="module")
def robot():
    return load_robot("servo_biped")


def _run(robot, travel_m: float, energy=None):
    q = np.tile(pin.neutral(robot.model), (T, 1))
    q[:, 0] = np.linspace(0.0, travel_m, T)
    joints = np.zeros((T, robot.n_actuated))
    trajectory = SimpleNamespace(
        q=q, v=np.zeros((T, robot.model.nv)), dt=DT, n_samples=T, joint_names=robot.joint_names
    )
    result = SimpleNamespace(
        t=np.arange(T) * DT, q=q, v=np.zeros((T, robot.model.nv)), q_joints_rad=joints,
        q_cmd_rad=joints + math.radians(1.0), fell=False, fall_time_s=None,
        simulated_until_s=(T - 1) * DT, energy=energy,
    )  # fmt: skip
    return trajectory, result


def _simulation(robot, travel_m: float = TRAVEL_M, energy=None):
    """A run restored from a project: no job (the law it ran is the servos')."""
    trajectory, result = _run(robot, travel_m, energy)
    job = SimulationJob((), ())
    return Simulation("test", robot, trajectory, job, 0.0, {"with compensation": result})


def _torques(robot):
    return SimpleNamespace(tau_Nm=np.ones((T, robot.n_actuated)))


def test_a_held_robot_carried_half_a_metre_draws_the_closed_form(robot):
    servo = sized_servos(robot)
    assert np.all(servo.compliance_deg_per_Nm == 1.4) and np.all(servo.backlash_deg == 0.5)
    text = IdealSRText().lines(_simulation(robot), _torques(robot), servo)
    stiffness = 1.0 / math.radians(1.4)  # N·m/rad
    tau = stiffness * math.radians(1.0 - 0.25)
    mx64 = load_catalogue()["mx64"]
    motor = mx64.fit().motor
    kt = motor.kt_Nm_per_A * 6.0 / mx64.stall_torque_Nm
    energy = robot.n_actuated * (tau / kt) ** 2 * motor.R_ohm * (T - 1) * DT
    match = re.search(
        r"with compensation: SR \*\*([0-9.]+)\*\* electrical \(ideal servo, stated motor\) · "
        r"([0-9.]+) planned work \(([0-9.]+) J over ([0-9.]+) m\)",
        text,
    )
    assert match, text
    sr, planned, joules, distance = (float(g) for g in match.groups())
    assert joules == pytest.approx(energy, abs=0.06)
    assert distance == pytest.approx(TRAVEL_M, abs=0.006)
    assert sr == pytest.approx(energy / (robot.mass_kg * 9.81 * TRAVEL_M), rel=0.005)
    assert planned == 0.0  # no joint moves: no planned work
    assert "stated motor: default motor per joint: 12 joint(s): mx64" in text


def test_no_line_in_place_on_parts_or_without_the_servos(robot):
    servo = sized_servos(robot)
    assert ideal_sr_lines(_simulation(robot, travel_m=0.05), _torques(robot), servo) == ""
    assert ideal_sr_lines(_simulation(robot, energy=object()), _torques(robot), servo) == ""
    # a run restored from a project whose servos changed since: the law it ran is not known
    assert ideal_sr_lines(_simulation(robot), _torques(robot), None) == ""
