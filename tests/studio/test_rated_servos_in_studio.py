"""Servos rated by a continuous point (Dynamixel-P) in the studio: offered in the Servos folder,
a joint on one takes a stiffness K [N·m/rad] in place of kp (k = 1/K, a bad one refused), kept
by a project, run by the simulation at K; *Size servos* picks one for a torque only it holds,
with the stiffness stated (the need rounded up). Figures typed from the PH54 pages
(emanual.robotis.com/docs/en/dxl/p/), as in tests/core/test_rated_servos.py."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from app.core.servo.choice import JointServo
from app.core.servo.kp_sizing import MAX_SAG_DEG, STAND_MARGIN
from app.core.simulation.part_law import PartLaw
from app.studio.servo_parts import catalogue
from tests.kp_brute_force import leg_stiffness_to_stand
from tests.studio.conftest import wait_for_signal, with_stand_torques

PH54_200 = "ph54_200_s500"
RPM = 2.0 * math.pi / 60.0
PEAK_NM = 44.7 / 9.3 * 22.74
"""PH54-200's peak: τc/Ic × the Current Limit register's top (22740 mA), from its page."""


@pytest.fixture
def studio(studio):
    return with_stand_torques(studio)


def pick(panel, joint: str, key: str) -> None:
    panel.joint.value = joint
    panel.servo.value = next(lab for lab in panel.servo.options if lab.startswith(key + " "))


def test_a_p_part_takes_a_stiffness_kept_by_a_project_run_by_the_simulation_and_sized(
    studio, tmp_path
):
    """One studio (one setup): picked by hand, then by *Size servos*."""
    robot, panel = studio.state.robot, studio.servo_rooms.servos.panel
    i = 3
    joint = robot.joint_names[i]
    before = float(studio.state.work.coefficients.servo.compliance_deg_per_Nm[i])
    pick(panel, joint, PH54_200)
    # The stiffness the joint had (1/its compliance, whole N·m/rad), shown in place of kp.
    start = max(1, round(1.0 / math.radians(before)))
    assert studio.state.work.parts.joint(joint) == JointServo(PH54_200, stiffness_Nm_per_rad=start)
    stiffness = panel.settings["stiffness_Nm_per_rad"]
    assert stiffness.visible and not stiffness.disabled and not panel.settings["kp"].visible
    assert panel.settings["current_limit_A"].value == pytest.approx(22.74)  # the register's A
    stiffness.value = 1200.0
    expected = math.degrees(1.0 / 1200.0)  # k = 1/K [°/(N·m)]
    coefficients = studio.state.work.coefficients
    assert coefficients.servo.compliance_deg_per_Nm[i] == pytest.approx(expected, rel=1e-12)
    assert coefficients.params.k_deg_per_Nm[i] == pytest.approx(expected, rel=1e-12)
    assert f"{expected:.3g} °/(N·m)" in panel.stiffness.content
    assert "K = 1200.0 N·m/rad (stated" in panel.stiffness.content
    good = studio.state.work.parts
    for bad in (0.0, -5.0):  # refused in one line, the last good kept and shown again
        stiffness.value = bad
        assert studio.state.work.parts is good
        assert "stiffness_Nm_per_rad" in panel.status.content
        assert "\n" not in panel.status.content and stiffness.value == 1200.0

    path = tmp_path / "p.bstudio"
    assert studio.project.save_as(str(path))
    panel.servo.value = "ideal servo"
    assert studio.state.work.parts.joint(joint) == JointServo()
    assert studio.project.open(str(path))
    assert studio.state.work.parts.joint(joint) == JointServo(PH54_200, stiffness_Nm_per_rad=1200)
    restored = studio.state.work.coefficients.servo.compliance_deg_per_Nm[i]
    assert restored == pytest.approx(expected, rel=1e-12)

    record = wait_for_signal(
        studio.state.work.on_simulation, lambda: studio.servo_rooms.simulation.simulate()
    )
    law = record.run.job.inputs[0].law
    assert isinstance(law, PartLaw) and list(np.flatnonzero(law.has_part)) == [i]
    assert law.stiffness_Nm_per_rad[i] == pytest.approx(1200.0, rel=1e-12)
    assert law.effort_Nm[i] == pytest.approx(PEAK_NM, rel=1e-12)
    assert law.kt_Nm_per_A[i] == pytest.approx(24.0 / (33.1 * RPM), rel=1e-12)  # V/ω0
    energy = record.run.results["with compensation"].energy
    assert energy is not None and energy.electrical_J[i] > 0.0

    # Sizing: 30 N·m held on the same joint all the motion (margin 0.3: 39 N·m to hold).
    session, load = studio.servo_rooms.servos, 30.0
    torques = studio.state.work.torques
    tau = np.array(torques.tau_Nm)
    tau[:, i] = load
    assert studio.state.work.set_torques(
        dataclasses.replace(torques, tau_Nm=tau), studio.state.trajectory
    )
    # Only PH54-200 holds 1.3 × 30 N·m: its continuous 44.7 N·m and peak τc/Ic × 22.74 A do;
    # PH54-100's 25.3 N·m continuous does not, nor does any stall-rated servo's stall torque.
    others = [r for k, r in session.records.items() if k != PH54_200]
    assert all((r.continuous_torque_Nm or r.stall_torque_Nm or 0.0) < 1.3 * load for r in others)
    session.panel.margin.value = 0.3
    sizing = wait_for_signal(session.sized, lambda: session.size_servos())
    assert not isinstance(sizing, str), sizing
    joint = robot.joint_names[i]
    # The need: the larger of the stand need (a leg joint) and (|τ| + friction at rest)/sag,
    # a PH54's DC model having no friction; stated rounded up to a whole N·m/rad.
    assert catalogue()[PH54_200].fit("m1").friction.friction_base_Nm == 0.0
    k_star, legs = leg_stiffness_to_stand(robot, studio.state.trajectory.q[0])
    need = max(load / math.radians(MAX_SAG_DEG), (1 + STAND_MARGIN) * k_star if i in legs else 0)
    stated = float(math.ceil(need))
    chosen = studio.state.work.parts.joint(joint)
    assert chosen == JointServo(PH54_200, stiffness_Nm_per_rad=stated)
    k = studio.state.work.coefficients.params.k_deg_per_Nm[i]
    assert k == pytest.approx(math.degrees(1.0 / stated), rel=1e-12)
    assert f"{joint}: **{PH54_200}**" in session.panel.sizing.content
    assert f"stiffness K {stated:g} N·m/rad stated" in session.panel.sizing.content
    session.panel.joint.value = joint
    assert session.panel.settings["stiffness_Nm_per_rad"].value == stated
