"""The servo catalogue: records complete and sourced, BAM's fits shipped unchanged, user files
checked like every input (one line naming the field)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from app.core.servo.catalogue import (
    BAM_PARAMS_DIR,
    FIGURES,
    ServoCatalogueError,
    identified_model,
    identified_names,
    load_catalogue,
    read_user_servos,
    with_user_servos,
)

SHARED_BAM = Path("/work/shared/actuators/bam/params")
BAM_SERVOS = ("mx64", "mx106", "xl320", "xl330")
RECORD = """\
key = "my_servo"
maker = "Acme"
model = "A-1"
supply_voltage_V = 12.0
stall_torque_Nm = 3.0
no_load_speed_rpm = 60
mass_kg = 0.08
gear_ratio = 250
[sources]
supply_voltage_V = "my bench"
stall_torque_Nm = "my bench"
no_load_speed_rpm = "my bench"
mass_kg = "kitchen scale"
gear_ratio = "teardown"
"""


def test_catalogue_holds_the_bam_servos_and_at_least_four_more_all_sourced():
    records = load_catalogue()
    identified = {r.identified for r in records.values() if r.identified}
    assert set(BAM_SERVOS) <= identified
    assert len([r for r in records.values() if r.identified is None]) >= 4
    for record in records.values():
        for name in FIGURES:
            if name == "stall_torque_Nm" and record.rated is not None:
                assert record.stall_torque_Nm is None  # rated by a continuous point instead
                name = "continuous_torque_Nm"
            value = getattr(record, name)
            assert math.isfinite(value) and value > 0, (record.key, name)
            assert record.sources[name].strip(), (record.key, name)


def test_datasheet_figures_read_as_robotis_publishes_them():
    # ROBOTIS e-Manual, MX-64: 7.3 N·m and 78 rev/min at 14.8 V, 135 g, 200:1, 0.33° backlash.
    mx64 = load_catalogue()["mx64"]
    assert (mx64.supply_voltage_V, mx64.stall_torque_Nm, mx64.no_load_speed_rpm) == (
        14.8,
        7.3,
        78,
    )
    assert (mx64.mass_kg, mx64.gear_ratio, mx64.backlash_deg) == (0.135, 200, 0.33)
    assert mx64.no_load_speed_rad_s == pytest.approx(78 * 2 * math.pi / 60)


def test_m1_fits_are_the_shared_files_unchanged():
    # Values typed from BAM's mx64/m1.json (independent of our loader and our copy).
    mx64 = identified_model("mx64")
    assert mx64.motor is not None
    assert mx64.motor.kt_Nm_per_A == 1.6224667906987444
    assert mx64.motor.R_ohm == 3.949433673232461
    assert mx64.m1.friction_base_Nm == 0.09038677246291783
    assert mx64.m1.friction_viscous_Nms == 0.011691602145974832
    if not SHARED_BAM.is_dir():
        pytest.skip("the shared BAM folder is not on this machine; the typed values above hold")
    for name in identified_names():
        for model in ("m1", "m6"):
            shared = SHARED_BAM / name / f"{model}.json"
            if shared.is_file():
                ours = BAM_PARAMS_DIR / name / f"{model}.json"
                assert json.loads(ours.read_text()) == json.loads(shared.read_text())
        fits = identified_model(name)
        raw = json.loads((SHARED_BAM / name / "m1.json").read_text())
        assert fits.m1.friction_base_Nm == raw["friction_base"]
        assert fits.m1.friction_viscous_Nms == raw["friction_viscous"]
        if fits.motor is not None:
            assert (fits.motor.kt_Nm_per_A, fits.motor.R_ohm) == (raw["kt"], raw["R"])
            assert fits.motor.armature_kgm2 == raw["armature"]


def test_a_user_servo_file_joins_the_catalogue(tmp_path):
    path = tmp_path / "mine.toml"
    path.write_text(RECORD)
    (record,) = read_user_servos(path)
    merged = with_user_servos(load_catalogue(), [record])
    assert merged["my_servo"].stall_torque_Nm == 3.0
    assert merged["my_servo"].law() is None  # no firmware, no fit: no motor law claimed


def test_user_servo_with_its_own_fit_and_firmware_gets_a_stiffness(tmp_path):
    path = tmp_path / "mine.toml"
    path.write_text(
        RECORD
        + 'firmware = "datasheet"\nmotor = "my identification"\n'
        + "[firmware]\nvin_V = 12.0\nkp = 10\nerror_gain = 0.1\nmax_pwm = 1.0\n"
        + "[motor]\nkt_Nm_per_A = 2.0\nR_ohm = 4.0\n"
    )
    (record,) = read_user_servos(path)
    law = record.law()
    assert law is not None
    from app.core.servo.motor_law import stiffness_Nm_per_rad

    assert stiffness_Nm_per_rad(*law) == pytest.approx(2.0 * 12.0 * 0.1 * 10 / 4.0)


@pytest.mark.parametrize(
    ("edit", "field"),
    [
        (lambda t: t.replace("mass_kg = 0.08\n", ""), "mass_kg is missing"),
        (lambda t: t.replace("stall_torque_Nm = 3.0", "stall_torque_Nm = -3.0"), "stall_torque_Nm"),
        (lambda t: t.replace("gear_ratio = 250", "gear_ratio = nan"), "gear_ratio"),
        (lambda t: t.replace("no_load_speed_rpm = 60", "no_load_speed_rpm = 0"), "no_load_speed"),
        (lambda t: t.replace('mass_kg = "kitchen scale"\n', ""), "mass_kg has no source"),
        (lambda t: t.replace("gear_ratio = 250", 'gear_ratio = "high"'), "gear_ratio"),
        (lambda t: t + "backlash_deg = -0.1\n", "backlash"),
        (lambda t: t.replace("model = ", "modle = "), "modle"),
    ],
)
def test_bad_user_servo_is_one_line_naming_the_field(tmp_path, edit, field):
    path = tmp_path / "bad.toml"
    text = edit(RECORD)
    if "backlash_deg = -0.1" in text:  # a top-level key must come before [sources]
        text = text.replace("backlash_deg = -0.1\n", "").replace(
            "[sources]", "backlash_deg = -0.1\n[sources]"
        )
    path.write_text(text)
    with pytest.raises(ServoCatalogueError) as caught:
        read_user_servos(path)
    message = str(caught.value)
    assert field in message and "\n" not in message


def test_a_user_key_already_in_the_catalogue_is_refused(tmp_path):
    path = tmp_path / "dup.toml"
    path.write_text(RECORD.replace('key = "my_servo"', 'key = "mx64"'))
    with pytest.raises(ServoCatalogueError, match="already used"):
        with_user_servos(load_catalogue(), read_user_servos(path))


def test_several_servos_in_one_file_and_hostile_files(tmp_path):
    path = tmp_path / "two.toml"
    second = RECORD.replace('key = "my_servo"', 'key = "my_other"')
    tables = "".join(
        "[[servo]]\n" + text.replace("[sources]", "[servo.sources]") for text in (RECORD, second)
    )
    path.write_text(tables)
    assert [r.key for r in read_user_servos(path)] == ["my_servo", "my_other"]
    path.write_bytes(b'key = "x" # \xff\xfe\n')
    with pytest.raises(ServoCatalogueError, match="UTF-8|utf-8"):
        read_user_servos(path)
    path.write_text("a = " + "[" * 200 + "]" * 200 + "\n")
    with pytest.raises(ServoCatalogueError, match="nested"):
        read_user_servos(path)
    path.write_text("[[servo]]\n" + RECORD.replace("[sources]", "[servo.sources]") + "mass = 1\n")
    with pytest.raises(ServoCatalogueError, match="mass is not a figure's source"):
        read_user_servos(path)
