"""The datasheet-only servos: why the simulation cannot run them, and the DC motor derived from
a datasheet's stall torque and no-load speed when the user gives the firmware's constants:
driven by the motor law in MuJoCo it stalls at the datasheet's torque and runs free at the
datasheet's speed (the figures themselves, not the derivation's formula), and its stiffness is
K = kt·vin·error_gain·kp/R = τs·error_gain·kp at the rated voltage."""

from __future__ import annotations

import math

import pytest

from app.core.servo.catalogue import (
    DATASHEET_ARMATURE_KGM2,
    load_catalogue,
    record_from_mapping,
    why_not_simulated,
)
from app.core.servo.choice import simulatable
from app.core.servo.motor_law import Firmware, datasheet_motor, drive, stiffness_Nm_per_rad
from app.core.simulation.mjcf import SimOptions
from tests.core.test_motor_law import _hold

DATASHEET_ONLY = ("mx28", "xc430_w240", "xh430_w350", "xh540_v270", "xm540_w270", "xw540_t260")
GAIN, KP, MAX_PWM = 0.158, 32.0, 0.95
"""A firmware the user would give (not published for these servos)."""
ARMATURE = 0.01


def rpm(value: float) -> float:
    return value * 2.0 * math.pi / 60.0


def test_the_datasheet_only_servos_say_why_they_are_not_simulated():
    catalogue = load_catalogue()
    cannot = sorted(key for key, record in catalogue.items() if why_not_simulated(record))
    assert tuple(cannot) == DATASHEET_ONLY
    assert not set(cannot) & set(simulatable(catalogue))
    why = why_not_simulated(catalogue["xm540_w270"])
    assert "no identified motor model and no firmware constants" in why
    assert "give [firmware]" in why


@pytest.mark.parametrize("key", DATASHEET_ONLY)
def test_the_derived_motor_stalls_and_runs_free_at_the_datasheets_figures(key):
    record = load_catalogue()[key]
    volts = record.supply_voltage_V
    motor = datasheet_motor(
        volts, MAX_PWM, record.stall_torque_Nm, rpm(record.no_load_speed_rpm), ARMATURE
    )
    firmware = Firmware(volts, KP, GAIN, MAX_PWM)
    # Stalled (held still, far from its target): the datasheet's stall torque.
    stalled = drive(1e4, 0.0, 0.0, motor, firmware)
    assert float(stalled.torque_Nm) == pytest.approx(record.stall_torque_Nm, rel=1e-12)
    # Free (no load, no gravity, in MuJoCo): it accelerates to the datasheet's no-load speed.
    _, dq = _hold(motor, firmware, 1e4, 0.01, 0.05, gravity=False, seconds=2.0, start=0.0)
    assert dq == pytest.approx(rpm(record.no_load_speed_rpm), rel=1e-4)
    # The P loop's stiffness: kt·vin·error_gain·kp/R = τs·error_gain·kp / max_pwm at vin = V.
    expected = record.stall_torque_Nm * GAIN * KP / MAX_PWM
    assert stiffness_Nm_per_rad(motor, firmware) == pytest.approx(expected, rel=1e-12)


def test_a_user_record_with_firmware_only_is_simulated_on_the_derived_motor():
    xm540 = load_catalogue()["xm540_w270"]
    data = {
        "key": "my_xm540",
        "maker": "ROBOTIS",
        "model": "XM540-W270, my firmware settings",
        **{f: getattr(xm540, f) for f in ("supply_voltage_V", "stall_torque_Nm",
                                          "no_load_speed_rpm", "mass_kg", "gear_ratio")},
        "firmware": {"vin_V": 12.0, "kp": KP, "error_gain": GAIN, "max_pwm": MAX_PWM},
        "sources": {**xm540.sources, "firmware": "my bench"},
    }  # fmt: skip
    data["sources"].pop("backlash_deg")
    record = record_from_mapping(data, "mine.toml")
    assert why_not_simulated(record) == ""
    assert "my_xm540" in simulatable({"my_xm540": record})
    fit = record.fit("m1")
    assert fit is not None and "derived from the datasheet" in fit.derived
    assert (fit.friction.friction_base_Nm, fit.friction.friction_viscous_Nms) == (0.0, 0.0)
    # an armature not published: the simulation's default, as the ideal servo has
    assert fit.motor.armature_kgm2 == DATASHEET_ARMATURE_KGM2 == SimOptions().armature_kgm2
    shown = record.to_json()["fits"]["m1"]
    assert shown["model_stall_torque_Nm"] == pytest.approx(10.6, rel=1e-12)  # at its 12 V
    assert shown["model_no_load_speed_rad_s"] == pytest.approx(rpm(30), rel=1e-12)
