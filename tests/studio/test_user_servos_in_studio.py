"""The user's own servo files in the studio's Servos folder: a TOML file added (as the upload
button hands it over) appears in the servo dropdown, sets k = 1/K from the motor law's closed
form of the file's own numbers, is kept with the project and checked again on open; bad files
are refused with one line naming the field, the work and the offered servos untouched."""

from __future__ import annotations

import dataclasses
import math

import pytest

from app.core.projects.codec import ProjectError
from app.core.projects.files import read_project
from app.core.projects.project import check_fits
from app.core.servo.user_files import MAX_FILE_BYTES, UserServoFile
from tests.studio.conftest import start_studio

KT, R, VIN, ERROR_GAIN, KP, MAX_PWM = 0.9, 3.5, 12.0, 0.158, 32.0, 0.95
"""The motor and firmware constants written in the user's file below."""


def servo_toml(key: str = "my_servo", stall: str = "4.2", motor: bool = True) -> str:
    """A user servo record: datasheet figures with sources, firmware and (optionally) an m1
    motor model."""
    text = f'''
key = "{key}"
maker = "Workshop"
model = "Test servo {key}"
supply_voltage_V = 12.0
stall_torque_Nm = {stall}
no_load_speed_rpm = 55
mass_kg = 0.08
gear_ratio = 250

[sources]
supply_voltage_V = "bench sheet"
stall_torque_Nm = "bench sheet"
no_load_speed_rpm = "bench sheet"
mass_kg = "kitchen scale"
gear_ratio = "teardown"
'''
    if motor:
        text += f"""firmware = "our firmware"
motor = "our bench fit"

[firmware]
vin_V = {VIN}
kp = {KP}
error_gain = {ERROR_GAIN}
max_pwm = {MAX_PWM}

[motor]
kt_Nm_per_A = {KT}
R_ohm = {R}
armature_kgm2 = 0.004
friction_base_Nm = 0.05
friction_viscous_Nms = 0.1
"""
    return text


@pytest.fixture
def studio(tmp_path):
    studio = start_studio(tmp_path / "data")
    yield studio
    studio.stop()


def labels_of(studio, key: str) -> list[str]:
    return [
        label
        for label in studio.servo_rooms.servos.panel.servo.options
        if label.startswith(key + " ")
    ]


def pick(studio, joint: str, key: str) -> None:
    panel = studio.servo_rooms.servos.panel
    panel.joint.value = joint
    (panel.servo.value,) = labels_of(studio, key)


def test_an_added_file_offers_its_servo_with_k_from_its_own_motor_model(studio):
    robot, session = studio.state.robot, studio.servo_rooms.servos
    assert not labels_of(studio, "my_servo")
    assert session.add_servo_file("mine.toml", servo_toml().encode())
    assert labels_of(studio, "my_servo") == ["my_servo — Workshop Test servo my_servo"]
    assert "my_servo" in session.records
    assert "Added 1 servo(s) from **mine.toml**" in session.panel.status.content
    joint = robot.joint_names[2]
    i = robot.joint_names.index(joint)
    pick(studio, joint, "my_servo")
    parts, coefficients = studio.state.work.parts, studio.state.work.coefficients
    assert parts.joint(joint).servo == "my_servo"
    expected = math.degrees(R / (KT * VIN * ERROR_GAIN * KP))  # 1/K, K = kt·vin·eg·kp/R
    assert coefficients.params.k_deg_per_Nm[i] == pytest.approx(expected, rel=1e-12)
    assert coefficients.servo.compliance_deg_per_Nm[i] == pytest.approx(expected, rel=1e-12)
    # The simulation's law is built from the user's part: its stall torque is the closed form.
    law_stall = KT * VIN * MAX_PWM / R
    assert f"stall {law_stall:.2f} N·m" in session.panel.stiffness.content


def test_bad_files_are_refused_in_one_line_and_nothing_is_lost(studio):
    session = studio.servo_rooms.servos
    assert session.add_servo_file("mine.toml", servo_toml().encode())
    joint = studio.state.robot.joint_names[1]
    pick(studio, joint, "my_servo")
    before, options = studio.state.work.parts, tuple(session.panel.servo.options)
    no_source = servo_toml("b").replace('mass_kg = "kitchen scale"\n', "")
    for name, content, said in (
        ("neg.toml", servo_toml("n", stall="-4.2").encode(), "stall_torque_Nm is -4.2"),
        ("nan.toml", servo_toml("n", stall="nan").encode(), "stall_torque_Nm is nan"),
        ("miss.toml", servo_toml("m").replace("mass_kg = 0.08\n", "").encode(), "mass_kg is"),
        ("src.toml", no_source.encode(), "mass_kg has no source"),
        ("text.toml", servo_toml("t", stall='"strong"').encode(), "give a number"),
        ("mx.toml", servo_toml("mx64").encode(), "key 'mx64' is already used by mx64.toml"),
        ("again.toml", servo_toml().encode(), "key 'my_servo' is already used by mine.toml"),
        ("bad key.toml", servo_toml("a b").encode(), "is not a servo key"),
        ("big.toml", b"#" * (MAX_FILE_BYTES + 1), "over 64 KiB is refused"),
        ("latin.toml", servo_toml().encode("utf-16"), "not UTF-8"),
        ("broken.toml", b"key = ", "not valid TOML"),
    ):
        assert not session.add_servo_file(name, content), name
        status = session.panel.status.content
        assert said in status, (name, status)
        assert "\n" not in status.strip(), "one line"
        assert "Traceback" not in status
        assert studio.state.work.parts is before, name
        assert tuple(session.panel.servo.options) == options, name


def test_a_file_of_the_same_name_replaces_the_earlier_and_a_datasheet_only_one_is_said(studio):
    session = studio.servo_rooms.servos
    assert session.add_servo_file("mine.toml", servo_toml().encode())
    joint = studio.state.robot.joint_names[0]
    pick(studio, joint, "my_servo")
    before = studio.state.work.parts
    # The corrected file drops my_servo while a joint uses it: refused, nothing lost.
    assert not session.add_servo_file("mine.toml", servo_toml("other").encode())
    assert "'my_servo' is not in the catalogue" in session.panel.status.content
    assert studio.state.work.parts is before
    # The same file, corrected kp: replaces the first; the joint on it takes its new k.
    halved = servo_toml().replace("kp = 32.0", "kp = 16.0")
    assert session.add_servo_file("mine.toml", halved.encode())
    assert [f.name for f in studio.state.work.parts.user_servos] == ["mine.toml"]
    i = studio.state.robot.joint_names.index(joint)
    expected = math.degrees(R / (KT * VIN * ERROR_GAIN * 16.0))
    assert studio.state.work.coefficients.params.k_deg_per_Nm[i] == pytest.approx(expected)
    # A record without a motor model is kept but not offered, and the folder says why.
    assert session.add_servo_file("sheet.toml", servo_toml("sheet_only", motor=False).encode())
    assert "not offered in *Servo*: sheet_only: no identified motor model and no firmware" in (
        session.panel.status.content
    )
    assert not labels_of(studio, "sheet_only")


def test_a_project_keeps_the_files_and_checks_them_on_open(studio, tmp_path):
    session = studio.servo_rooms.servos
    assert session.add_servo_file("mine.toml", servo_toml().encode())
    joint = studio.state.robot.joint_names[3]
    pick(studio, joint, "my_servo")
    path = tmp_path / "mine.bstudio"
    assert studio.project.save_as(str(path))
    project = read_project(path)
    assert project.servo_parts.user_servos == (UserServoFile("mine.toml", servo_toml()),)
    assert project.servo_parts.joint(joint).servo == "my_servo"
    # Back to the ideal servo and the file gone from the state, then the project opened.
    session.restore_parts(None, (None, None))
    assert studio.state.work.parts.user_servos == ()
    assert not labels_of(studio, "my_servo")
    assert studio.project.open(str(path))
    assert studio.state.work.parts.joint(joint).servo == "my_servo"
    assert labels_of(studio, "my_servo")
    # A project whose stored file was tampered with is refused, naming the field.
    bad_file = UserServoFile("mine.toml", servo_toml(stall="-1"))
    bad = dataclasses.replace(project.servo_parts, user_servos=(bad_file,))
    with pytest.raises(ProjectError, match="stall_torque_Nm is -1"):
        check_fits(dataclasses.replace(project, servo_parts=bad), studio.state.robot)
    missing = dataclasses.replace(project.servo_parts, user_servos=())
    with pytest.raises(ProjectError, match="'my_servo' is not in the catalogue"):
        check_fits(dataclasses.replace(project, servo_parts=missing), studio.state.robot)


def test_the_folder_says_why_the_datasheet_only_servos_are_not_offered(studio):
    note = studio.servo_rooms.servos.panel.not_offered.content
    for key in ("mx28", "xc430_w240", "xh430_w350", "xh540_v270", "xm540_w270", "xw540_t260"):
        assert key in note
        assert not labels_of(studio, key)
    assert "no identified motor model and no firmware constants" in note


def test_a_file_with_firmware_but_no_motor_runs_a_dc_motor_from_its_datasheet(studio):
    session = studio.servo_rooms.servos
    text = servo_toml("dc_servo", motor=False) + (
        f'firmware = "our firmware"\n\n[firmware]\nvin_V = 12.0\nkp = {KP}\n'
        f"error_gain = {ERROR_GAIN}\nmax_pwm = {MAX_PWM}\n"
    )
    assert session.add_servo_file("dc.toml", text.encode())
    assert "derived from the datasheet" in session.panel.status.content
    joint = studio.state.robot.joint_names[1]
    pick(studio, joint, "dc_servo")
    i = studio.state.robot.joint_names.index(joint)
    # kt = V·max_pwm/ω0, R = kt·V·max_pwm/τs give K = kt·vin·eg·kp/R = τs·eg·kp/max_pwm at
    # vin = V: the file's stall torque 4.2 N·m at its 12 V.
    stiffness = 4.2 * ERROR_GAIN * KP / MAX_PWM
    k = studio.state.work.coefficients.params.k_deg_per_Nm[i]
    assert k == pytest.approx(math.degrees(1.0 / stiffness), rel=1e-12)
    assert "stall 4.20 N·m" in session.panel.stiffness.content


def test_removing_a_file_puts_its_joints_on_the_ideal_servo_and_undo_brings_it_back(studio):
    robot, session = studio.state.robot, studio.servo_rooms.servos
    panel = session.panel
    assert panel.remove_file.disabled  # nothing to remove yet
    assert session.add_servo_file("mine.toml", servo_toml().encode())
    assert session.add_servo_file("other.toml", servo_toml("other").encode())
    assert panel.user_file.options == ("mine.toml", "other.toml")
    assert not panel.remove_file.disabled
    joint, kept = robot.joint_names[2], robot.joint_names[3]
    i = robot.joint_names.index(joint)
    pick(studio, joint, "my_servo")
    pick(studio, kept, "other")
    studio.project.autosave.now()  # the work with both files: a step
    one_over_k = math.degrees(R / (KT * VIN * ERROR_GAIN * KP))  # 1/K of the file's part

    assert session.remove_servo_file("mine.toml")
    parts = studio.state.work.parts
    assert parts.joint(joint).is_ideal and parts.joint(kept).servo == "other"
    assert [f.name for f in parts.user_servos] == ["other.toml"]
    assert not labels_of(studio, "my_servo") and labels_of(studio, "other")
    assert panel.user_file.options == ("other.toml",)
    said = panel.status.content
    assert "Removed **mine.toml** (my_servo)" in said and joint in said and kept not in said
    assert "ideal servo" in said and "\n" not in said
    assert studio.notifier.last.title == "Servo file removed"
    # back on the ideal servo, the joint keeps the compliance its part had (1/K)
    servo = studio.state.work.coefficients.servo
    assert servo.compliance_deg_per_Nm[i] == pytest.approx(one_over_k, rel=1e-12)

    studio.project.autosave.now()
    assert studio.project.undo()
    parts = studio.state.work.parts
    assert parts.joint(joint).servo == "my_servo"
    assert [f.name for f in parts.user_servos] == ["mine.toml", "other.toml"]
    assert labels_of(studio, "my_servo")
    assert "Undid: servo file mine.toml removed" in studio.project.panel.status.content


def test_removing_a_file_that_is_not_kept_is_refused_in_one_line(studio):
    session = studio.servo_rooms.servos
    assert session.add_servo_file("mine.toml", servo_toml().encode())
    before = studio.state.work.parts
    assert not session.remove_servo_file("nope.toml")
    assert (
        "no servo file named 'nope.toml' is kept (kept: mine.toml)" in session.panel.status.content
    )
    assert studio.state.work.parts is before
