"""In a real headless Chromium: the Servos folder. A motion and its torques are made by clicking
(Motions, Compensation), then a catalogue servo is picked for a joint from the Servos folder's
dropdowns, the page shows its compliance k = 1/K (checked against the motor law's closed form,
K = kt·vin·error_gain·kp/R, from the record), a margin is typed, *Size servos* is clicked and
the per-joint choice and its margins are read in the page, against the studio's state and a
brute force over the servos offered and their kp (tests/kp_brute_force.py); a stand margin is
typed beside *Size servos* and the kp it changes are read in the page against the same brute
force with that margin (a bad one refused in one line, the last good kept). Last, the user's own servo file is uploaded through the
folder's upload button (a bad one first: refused in one line, nothing changed), its servo
picked from the dropdown and its k = 1/K read in the page against the file's own numbers. A
Dynamixel-P part picked from the dropdown shows a stiffness input in place of kp's, and the
stiffness typed there gives the compliance line k = 1/K.

The page is loaded once for the module: run the tests together, in file order.
"""

from __future__ import annotations

import math
import re

import pytest

from app.core.servo.kp_sizing import MAX_SAG_DEG, STAND_MARGIN
from app.core.servo.sizing import check_joint
from app.studio import Studio
from app.studio.servo_parts import catalogue
from tests.browser.page_helpers import (
    RENDER_TIMEOUT_S,
    UI_TIMEOUT_S,
    chart_pixels,
    click_button,
    compute_torques_in_page,
    expand_folder,
    folder,
    generate_motion,
    gui_row_input,
    pause_playback,
    select_option,
    type_number,
    wait_for,
    wait_notified,
)
from tests.kp_brute_force import studio_sizing_pairs
from tests.studio.test_user_servos_in_studio import ERROR_GAIN, KP, KT, VIN, R, servo_toml

MOTION = "one_leg_stand"
ENVELOPE_RGB, POINTS_RGB = (0x1F, 0x77, 0xB4), (0xD6, 0x27, 0x28)
"""The torque-speed chart's envelope and planned points (panels.servos_panel)."""
MIN_CHART_PIXELS = 20
"""Envelope lines span the chart and a planned point is 4 px across; an empty chart has none."""
JOINT = "left_knee"
SERVO = "mx64"
MARGIN = 0.2
TYPED_STAND_MARGIN = 1.0
"""Above the default 0.5: on the one-leg stand, hip pitch kp 19 → 26 (standing sets it)."""


def test_pick_a_catalogue_servo_for_a_joint(page, studio: Studio) -> None:
    generate_motion(page, studio, MOTION)
    compute_torques_in_page(page, studio, "the torques' quick estimate")

    expand_folder(page, "Servos", "Size servos")
    assert JOINT in studio.state.robot.joint_names
    select_option(page, "Servo of joint", JOINT)
    record = catalogue()[SERVO]
    select_option(page, "Servo", f"{SERVO} — {record.maker} {record.model}")
    parts = wait_for(
        f"{SERVO} on {JOINT} in the studio",
        lambda: (p := studio.state.work.parts) is not None and p.joint(JOINT).servo == SERVO and p,
        UI_TIMEOUT_S,
    )
    assert parts.chosen == (JOINT,)
    fit, firmware = record.fit("m1"), record.firmware
    stiffness = (
        fit.motor.kt_Nm_per_A * firmware.vin_V * firmware.error_gain * firmware.kp / fit.motor.R_ohm
    )
    shown = f"k = 1/K = {math.degrees(1.0 / stiffness):.3g} °/(N·m)"
    servos = folder(page, "Servos")
    servos.get_by_text(shown, exact=False).wait_for(state="visible", timeout=UI_TIMEOUT_S * 1000)
    i = studio.state.robot.joint_names.index(JOINT)
    k = studio.state.work.coefficients.params.k_deg_per_Nm[i]
    assert k == pytest.approx(math.degrees(1.0 / stiffness), rel=1e-12)


def test_size_servos_shows_the_choice_and_its_margins(page, studio: Studio) -> None:
    assert studio.state.work.prediction is not None, "run with the test before"
    type_number(page, "Margin", MARGIN)
    wait_for(
        f"the margin {MARGIN}",
        lambda: studio.servo_rooms.servos.panel.margin.value == pytest.approx(MARGIN),
        UI_TIMEOUT_S,
    )
    before = studio.state.work.parts
    click_button(page, "Size servos")
    servos = folder(page, "Servos")
    servos.get_by_text("Sized against", exact=False).wait_for(
        state="visible", timeout=RENDER_TIMEOUT_S * 1000
    )
    parts = wait_for(
        "the sized parts", lambda: (p := studio.state.work.parts) is not before and p, UI_TIMEOUT_S
    )
    # The selected joint's torque-speed chart draws its envelope and planned points (it drew
    # nothing while the points' column held gaps at the envelope's speeds).
    wait_for(
        "the torque-speed chart drawn",
        lambda: min(chart_pixels(page, "Servos", (ENVELOPE_RGB, POINTS_RGB))) >= MIN_CHART_PIXELS,
        UI_TIMEOUT_S,
    )
    text = servos.inner_text()
    assert f"margin {MARGIN:.0%}" in text
    robot = studio.state.robot
    _, works = studio.servo_rooms.servos.last
    (work,) = works.values()
    pairs = studio_sizing_pairs(studio, MARGIN)
    for j, (name, (expected, kp)) in enumerate(zip(robot.joint_names, pairs, strict=True)):
        expected = expected or ""
        assert (parts.joint(name).servo, parts.joint(name).kp) == (expected, kp), name
        if expected:
            said = (
                f"kp {kp:g}" if kp is not None else r"stiffness K \d+ N·m/rad stated"
            )  # no kp law
            line = re.search(
                rf"^{re.escape(name)}: {expected}, peak margin ([+-](?:\d+|inf))%.*, {said} ",
                text,
                re.M,
            )
            assert line is not None, f"{name}'s choice and kp are not in the page:\n{text}"
            check = check_joint(
                studio.servo_rooms.servos.records[expected], work.speed_rad_s[:, j], work.torque_Nm[:, j],
                1.0, MARGIN,
            )  # fmt: skip
            shown_margin = float(line.group(1))
            assert shown_margin == (
                math.inf if math.isinf(check.peak_margin) else round(100 * check.peak_margin)
            )
            assert check.peak_margin >= MARGIN
        else:
            assert re.search(rf"{re.escape(name)}: no servo holds it", text), name


def test_a_stand_margin_typed_changes_the_kp_the_sizing_chooses(page, studio: Studio) -> None:
    pause_playback(page)
    before = studio.state.work.parts
    assert before is not None and before.stand_margin == STAND_MARGIN, "run the tests before"
    type_number(page, "Stand margin", TYPED_STAND_MARGIN)
    wait_for(
        f"the stand margin {TYPED_STAND_MARGIN:g} in the studio",
        lambda: (p := studio.state.work.parts) is not None and p.stand_margin == TYPED_STAND_MARGIN,
        UI_TIMEOUT_S,
    )
    before = studio.state.work.parts
    click_button(page, "Size servos")
    servos = folder(page, "Servos")
    servos.get_by_text(
        f"stand margin {TYPED_STAND_MARGIN:g}, sag ≤ {MAX_SAG_DEG:g}°", exact=False
    ).wait_for(state="visible", timeout=RENDER_TIMEOUT_S * 1000)
    parts = wait_for(
        "the sized parts", lambda: (p := studio.state.work.parts) is not before and p, UI_TIMEOUT_S
    )
    text = servos.inner_text()
    robot = studio.state.robot
    pairs = studio_sizing_pairs(studio, MARGIN, stand_margin=TYPED_STAND_MARGIN)
    changed = []
    for name, (servo, kp) in zip(robot.joint_names, pairs, strict=True):
        assert (parts.joint(name).servo or None, parts.joint(name).kp) == (servo, kp), name
        if servo is not None and kp != before.joint(name).kp:
            changed.append(name)
            line = rf"^{re.escape(name)}: {servo}, peak margin .*, kp {kp:g} \(sag"
            assert re.search(line, text, re.M), f"{name}'s new kp {kp:g} is not in the page"
    assert changed, "the typed stand margin changed no joint's kp"

    # a bad value: one line, the last good one kept (in the studio and in the page)
    type_number(page, "Stand margin", -1.0)
    wait_notified(page, "Sizing bound refused", "stand margin is -1", UI_TIMEOUT_S)
    servos.get_by_text("stand margin is -1; give a number in [0, 10]", exact=False).wait_for(
        state="visible", timeout=UI_TIMEOUT_S * 1000
    )
    box = gui_row_input(page, "Stand margin", "input.mantine-NumberInput-input")
    wait_for(
        "the page to show the last good stand margin",
        lambda: box.input_value() == f"{TYPED_STAND_MARGIN:g}",
        UI_TIMEOUT_S,
    )
    assert studio.state.work.parts is parts


def upload(page, name: str, text: str) -> None:
    """The user's file through the Servos folder's upload button and the browser's chooser."""
    with page.expect_file_chooser() as chooser:
        click_button(page, "Add servo file (.toml)")
    chooser.value.set_files(
        files=[{"name": name, "mimeType": "application/toml", "buffer": text.encode()}]
    )


def test_a_user_servo_file_uploaded_is_offered_and_picked(page, studio: Studio) -> None:
    expand_folder(page, "Servos", "Add servo file (.toml)")
    servos = folder(page, "Servos")
    # the catalogue's datasheet-only servos are not offered, and the folder says why
    servos.get_by_text("Not offered (datasheet only: mx28", exact=False).wait_for(
        state="visible", timeout=UI_TIMEOUT_S * 1000
    )
    assert "no identified motor model and no firmware constants" in servos.inner_text()
    before = studio.state.work.parts
    upload(page, "bad.toml", servo_toml("my_servo", stall="-4.2"))
    wait_notified(page, "Servo file refused", "stall_torque_Nm is -4.2", UI_TIMEOUT_S)
    servos.get_by_text("stall_torque_Nm is -4.2", exact=False).wait_for(
        state="visible", timeout=UI_TIMEOUT_S * 1000
    )
    assert studio.state.work.parts is before
    assert "my_servo" not in studio.servo_rooms.servos.records

    upload(page, "mine.toml", servo_toml("my_servo"))
    servos.get_by_text("Added 1 servo(s) from mine.toml", exact=False).wait_for(
        state="visible", timeout=UI_TIMEOUT_S * 1000
    )
    joint = studio.state.robot.joint_names[0]
    select_option(page, "Servo of joint", joint)
    select_option(page, "Servo", "my_servo — Workshop Test servo my_servo")
    parts = wait_for(
        f"my_servo on {joint} in the studio",
        lambda: (
            (p := studio.state.work.parts) is not None and p.joint(joint).servo == "my_servo" and p
        ),
        UI_TIMEOUT_S,
    )
    assert [f.name for f in parts.user_servos] == ["mine.toml"]
    compliance = math.degrees(R / (KT * VIN * ERROR_GAIN * KP))  # 1/K of the file's numbers
    servos.get_by_text(f"k = 1/K = {compliance:.3g} °/(N·m)", exact=False).wait_for(
        state="visible", timeout=UI_TIMEOUT_S * 1000
    )


def test_a_p_part_picked_shows_a_stiffness_in_place_of_kp(page, studio: Studio) -> None:
    """PH54-200 (rated by a continuous point, no kp law): K typed, k = 1/K read in the page."""
    joint, key = "right_knee", "ph54_200_s500"
    record = catalogue()[key]
    select_option(page, "Servo of joint", joint)
    select_option(page, "Servo", f"{key} — {record.maker} {record.model}")
    wait_for(
        f"{key} on {joint} in the studio",
        lambda: (p := studio.state.work.parts) is not None and p.joint(joint).servo == key,
        UI_TIMEOUT_S,
    )
    servos = folder(page, "Servos")
    for label, state in (("Stiffness K [N·m/rad]", "visible"), ("kp (firmware)", "hidden")):
        servos.locator("label", has_text=re.compile(rf"^{re.escape(label)}$")).wait_for(
            state=state, timeout=UI_TIMEOUT_S * 1000
        )
    type_number(page, "Stiffness K [N·m/rad]", 1200.0)
    servos.get_by_text(f"k = 1/K = {math.degrees(1.0 / 1200.0):.3g} °/(N·m)", exact=False).wait_for(
        state="visible", timeout=UI_TIMEOUT_S * 1000
    )
    assert studio.state.work.parts.joint(joint).stiffness_Nm_per_rad == 1200.0
