"""Servos rated by a continuous point (Dynamixel-P): the records against their pages' figures
(typed here from the pages), the DC motor through the published points against its closed
form and the motor law, the servo.toml's stated stiffness, and sizing Roban S14's stance hip
roll, its torque from pinocchio's RNEA with the whole robot on one foot."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from app.core.servo import motor_law
from app.core.servo.catalogue import ServoCatalogueError, load_catalogue, record_from_mapping
from app.core.servo.parts import ServoPartsError, parts_from_mapping
from app.core.servo.sizing import envelope, size_joints
from app.core.simulation.part_law import part_servo_law

RPM = 2.0 * math.pi / 60.0
# Typed from the pages (emanual.robotis.com/docs/en/dxl/p/<model>/): 24 V; no-load speed
# [rpm] and current [A]; continuous speed [rpm], torque [N·m], current [A]; weight [g]; gear
# ratio; the control table's Current Limit(38) top [mA].
PAGES = {
    "ph54_200_s500": (33.1, 1.65, 29.0, 44.7, 9.3, 855, 501.923, 22740),
    "ph54_100_s500": (33.3, 1.13, 29.2, 25.3, 5.5, 740, 501.923, 15900),
    "ph42_020_s300": (32.7, 0.57, 29.2, 5.1, 1.5, 340, 303.75, 4500),
}


@pytest.fixture(scope="module")
def catalogue():
    return load_catalogue()


@pytest.mark.parametrize("key", sorted(PAGES))
def test_records_are_the_pages_figures_and_publish_no_stall_torque(catalogue, key):
    w0, i0, wc, tc, ic, grams, gear, limit_mA = PAGES[key]
    record = catalogue[key]
    rated = record.rated
    assert rated is not None and record.stall_torque_Nm is None and not record.kp_law
    assert (record.supply_voltage_V, record.no_load_speed_rpm, record.continuous_torque_Nm) == (
        24.0, w0, tc,
    )  # fmt: skip
    assert (rated.no_load_current_A, rated.continuous_speed_rpm, rated.continuous_current_A) == (
        i0, wc, ic,
    )  # fmt: skip
    assert record.mass_kg == pytest.approx(grams / 1000) and record.gear_ratio == gear
    assert record.backlash_deg == 0.1 and rated.max_pwm == 1.0
    assert rated.current_limit_A == pytest.approx(limit_mA / 1000)
    page = f"https://emanual.robotis.com/docs/en/dxl/p/{key.replace('_', '-')}-r/"
    for name in ("no_load_speed_rpm", "continuous_torque_Nm", "mass_kg", "drive"):
        assert record.sources[name].startswith(page)
    assert "Position P Gain(532)" in record.sources["drive"]


@pytest.mark.parametrize("key", sorted(PAGES))
def test_the_motor_passes_through_both_published_points(catalogue, key):
    """kt = V/ω0, R = kt²(ω0 − ωc)/τc from the page's figures; the motor law at full duty
    then runs free at ω0 and gives τc at ωc; the envelope caps at τc/Ic × the current limit."""
    w0, _i0, wc, tc, ic, _g, _gear, limit_mA = PAGES[key]
    kt = 24.0 / (w0 * RPM)
    r = kt**2 * (w0 - wc) * RPM / tc
    record = catalogue[key]
    fit = record.fit("m1")
    assert fit is not None and fit.derived
    assert fit.motor.kt_Nm_per_A == pytest.approx(kt, rel=1e-12)
    assert fit.motor.R_ohm == pytest.approx(r, rel=1e-12)
    firmware = motor_law.Firmware(24.0, 1.0, 1.0, 1.0)  # saturated: duty = max_pwm
    big_error = 1.0e3
    free = motor_law.drive(big_error, 0.0, w0 * RPM, fit.motor, firmware).torque_Nm
    rated = motor_law.drive(big_error, 0.0, wc * RPM, fit.motor, firmware).torque_Nm
    assert float(free) == pytest.approx(0.0, abs=1e-9)
    assert float(rated) == pytest.approx(tc, rel=1e-12)
    env = envelope(record)
    assert env.torque_limit_Nm == pytest.approx(tc / ic * limit_mA / 1000, rel=1e-12)
    assert float(env.max_torque_Nm(np.array([wc * RPM]))[0]) == pytest.approx(tc, rel=1e-12)


def test_the_servo_toml_states_its_stiffness_and_the_part_law_follows(catalogue):
    names = ["hip_roll", "knee"]
    data = {"joints": {
        "hip_roll": {"servo": "ph54_200_s500", "stiffness_Nm_per_rad": 1200},
        "knee": {"servo": "mx106", "kp": 95},
    }}  # fmt: skip
    parts = parts_from_mapping(data, names, catalogue, "servo.toml")
    hip, _knee = parts.parts
    assert hip.stiffness_Nm_per_rad == pytest.approx(1200.0, rel=1e-12)
    assert parts.to_json()[0]["kp"] is None and parts.to_json()[1]["kp"] == 95
    law = part_servo_law(parts)
    rated = catalogue["ph54_200_s500"].rated
    assert law.stiffness_Nm_per_rad[0] == pytest.approx(1200.0, rel=1e-12)
    # the law's torque cap: the current limit's τc/Ic × 22.74 A, below the line's D·ω0
    assert law.effort_Nm[0] == pytest.approx(44.7 / 9.3 * 22.74, rel=1e-12)
    assert law.back_emf_Nms_per_rad[0] == pytest.approx(44.7 / ((33.1 - 29.0) * RPM), rel=1e-12)
    assert rated is not None and law.effort_Nm[0] < rated.line_stall_torque_Nm
    for table, words in (
        ({"servo": "ph54_200_s500", "kp": 300}, "no kp law"),
        ({"servo": "ph54_200_s500"}, "stiffness_Nm_per_rad"),
        ({"servo": "mx106", "stiffness_Nm_per_rad": 100}, "has a kp law"),
        ({"servo": "ph54_200_s500", "stiffness_Nm_per_rad": 1, "current_limit_A": 30}, "22.74"),
    ):
        with pytest.raises(ServoPartsError, match=words):
            parts_from_mapping({"joints": {"j": table}}, ["j"], catalogue, "servo.toml")


@pytest.mark.parametrize(
    ("edit", "words"),
    [
        ({"continuous_speed_rpm": 40.0}, "below"),
        ({"continuous_current_A": 1.0}, "must exceed"),
        ({"stall_torque_Nm": 100.0}, "not both"),
        ({"drive": None}, "needs a [drive] table"),
    ],
)
def test_a_bad_rated_record_is_one_line(catalogue, edit, words):
    record = catalogue["ph54_200_s500"]
    data = {
        "key": "mine", "maker": "m", "model": "m", "supply_voltage_V": 24.0,
        "no_load_speed_rpm": 33.1, "no_load_current_A": 1.65, "continuous_speed_rpm": 29.0,
        "continuous_torque_Nm": 44.7, "continuous_current_A": 9.3, "mass_kg": 0.855,
        "gear_ratio": 501.923,
        "drive": {"max_pwm": 1.0, "current_limit_A": 22.74, "p_gain_max": 32767},
        "sources": dict(record.sources),
    }  # fmt: skip
    record_from_mapping(data, "mine.toml")  # as given: a good record
    data.update(edit)
    data = {k: v for k, v in data.items() if v is not None}
    data["sources"] = {**record.sources, "stall_torque_Nm": "x"}
    with pytest.raises(ServoCatalogueError, match=re_escape(words)):
        record_from_mapping(data, "mine.toml")


def re_escape(text: str) -> str:
    import re

    return re.escape(text)


def _one_leg_joint_torques(robot, q: np.ndarray, foot_frame: str) -> np.ndarray:
    """The actuated joints' torques holding the robot still on one foot: RNEA's gravity
    torques less the foot wrench that zeroes the floating base's rows (pinocchio)."""
    model = robot.model
    data = model.createData()
    g = pin.rnea(model, data, q, np.zeros(model.nv), np.zeros(model.nv))
    frame = model.getFrameId(foot_frame)
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    jac = pin.getFrameJacobian(model, data, frame, pin.LOCAL_WORLD_ALIGNED)
    wrench = np.linalg.solve(jac[:, :6].T, g[:6])
    tau = g - jac.T @ wrench
    assert np.allclose(tau[:6], 0.0, atol=1e-9)
    return np.array([tau[j.idx_v] for j in robot.joints])


def test_s14s_stance_hip_roll_gets_a_servo_whose_continuous_rating_holds_it(catalogue):
    from app.core.posing.ready_pose import ready_pose
    from app.core.robot.loading import load_robot
    from tests.conftest import ROBAN_URDF

    robot = load_robot(str(ROBAN_URDF))
    q = ready_pose(robot).q
    tau = _one_leg_joint_torques(robot, q, robot.foot("left").link)
    hip_roll = robot.joint_names.index("leg_l2_joint")
    load = abs(tau[hip_roll])
    assert load > 10.0  # the whole upper body and the other leg about the stance hip
    held = np.full((20, 1), load)
    sizing = size_joints(["leg_l2_joint"], np.zeros_like(held), held, 1.0, catalogue, 0.3)
    choice = sizing.joints[0].choice
    assert choice is not None
    chosen = catalogue[choice]
    assert chosen.continuous_torque_Nm is not None and chosen.continuous_torque_Nm >= 1.3 * load
    # the lightest whose published continuous rating and current-limited peak hold 1.3× the
    # load, from the pages' figures (a stall-rated servo's assumed quarter of stall: MX-106
    # 2.7, MX-64 1.8 N·m, none near): brute force over PAGES
    fits = [
        (grams, key)
        for key, (_w0, _i0, _wc, tc, ic, grams, _gear, limit_mA) in PAGES.items()
        if tc >= 1.3 * load and tc / ic * limit_mA / 1000 >= 1.3 * load
    ]
    assert choice == min(fits)[1]


def test_the_part_sags_as_its_stated_stiffness_says_and_stalls_at_its_current_limit(catalogue):
    """In MuJoCo (the motor law's pendulum): a PH54-200 part at a stated K holds a 2 kg arm of
    1 m with K·e = m·g·l·cos(e); held far from its target it gives τc/Ic × 22.74 A."""
    from scipy.optimize import brentq

    from tests.core.test_motor_law import _hold

    data = {"joints": {"j": {"servo": "ph54_200_s500", "stiffness_Nm_per_rad": 1159}}}
    (part,) = parts_from_mapping(data, ["j"], catalogue, "servo.toml").parts
    mass, length = 2.0, 1.0
    sag = brentq(lambda e: 1159.0 * e - mass * 9.81 * length * math.cos(e), 0.0, 1.0)
    q, dq = _hold(part.motor, part.firmware, 0.0, mass, length)
    assert abs(dq) < 1e-6 and -q == pytest.approx(sag, rel=1e-3)
    stalled = motor_law.drive(1.0e4, 0.0, 0.0, part.motor, part.firmware).torque_Nm
    assert float(stalled) == pytest.approx(44.7 / 9.3 * 22.74, rel=1e-12)


def test_biped_studio_servos_lists_them_without_a_stall_torque():
    import json

    from tests.test_cli import run

    result = run("servos", "--json")
    assert result.returncode == 0, result.stderr
    rows = {row["key"]: row for row in json.loads(result.stdout)["servos"]}
    for key, (_w0, _i0, _wc, tc, _ic, grams, _gear, _limit) in PAGES.items():
        row = rows[key]
        assert row["stall_torque_Nm"] is None and row["continuous_torque_Nm"] == tc
        assert row["mass_kg"] == pytest.approx(grams / 1000)
        assert row["not_simulated"] is None and "no kp law" in row["kp_law"]
        assert row["rated"]["torque_limit_Nm"] < row["rated"]["line_stall_torque_Nm"]
    text = run("servos").stdout.splitlines()
    (line,) = [ln for ln in text if ln.startswith("ph54_200_s500 ")]
    assert "44.70" in line and line.endswith("DC model (continuous point)")
