"""A joint name the robot lacks is refused with one line, by every reader of per-joint values
(compensation coefficients, virtual servos, servo parts and masses, torque CSVs)."""

from __future__ import annotations

import pytest

from app.core.errors import StudioError, refuse_unknown_joints
from app.core.servo.compensation import CompensationError, CompensationParams
from app.core.servo.files import read_torque_csv
from app.core.servo.masses import ServoMassError, with_servo_masses
from app.core.servo.model import ServoModel, ServoModelError

JOINTS = ("hip", "knee", "ankle")


def test_every_unknown_name_and_the_known_ones_are_said():
    refuse_unknown_joints(["knee", "hip"], JOINTS)  # all known: nothing
    with pytest.raises(StudioError) as info:
        refuse_unknown_joints(["knee", "kne", "toe"], JOINTS, where="k.toml", robot="bot")
    assert str(info.value) == (
        "k.toml: no joint named 'kne', 'toe' on bot; its joints are: hip, knee, ankle"
    )


def test_the_records_and_readers_say_it_alike(tmp_path, servo_biped):
    params = CompensationParams(("kne",), [1.0], [0.0], [True])
    with pytest.raises(CompensationError, match=r"^no joint named 'kne' on this robot; its"):
        params.for_joints(JOINTS)
    with pytest.raises(ServoModelError, match=r"^no joint named 'kne' on this robot; its"):
        ServoModel(("kne",), [1.0], [0.0]).for_joints(JOINTS)
    laid = params.for_joints(("ankle", "kne"))  # known: laid out, the others off
    assert laid.enabled.tolist() == [False, True] and laid.k_deg_per_Nm.tolist() == [0.0, 1.0]
    path = tmp_path / "tau.csv"
    path.write_text("t [s],tau:hip [N·m],tau:toe [N·m]\n0,1,2\n")
    with pytest.raises(CompensationError, match=r"tau.csv: tau:<joint>: no joint named 'toe'"):
        read_torque_csv(path, JOINTS)
    with pytest.raises(ServoMassError, match=r"no joint named 'elbow' on servo_biped; its"):
        with_servo_masses(servo_biped, {"elbow": 0.1})
