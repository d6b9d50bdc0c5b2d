"""Sizing against independent references: a brute-force search written from the DC motor's
inequalities, the motor law's closed forms (read from BAM's files here, not through the code
under test), and a catalogue copy with one figure changed."""

from __future__ import annotations

import json
import math
import shutil

import numpy as np
import pytest

from app.core.servo import motor_law
from app.core.servo.catalogue import (
    BAM_PARAMS_DIR,
    SERVOS_DIR,
    load_catalogue,
    record_from_mapping,
)
from app.core.servo.sizing import (
    CONTINUOUS_FRACTION_OF_STALL,
    SizingError,
    envelope,
    size_joints,
)

SOURCES = {
    name: "constructed for the test"
    for name in ("supply_voltage_V", "stall_torque_Nm", "no_load_speed_rpm", "mass_kg")
}


def _record(key: str, stall: float, rpm: float, mass: float, **extra):
    data = {
        "key": key,
        "maker": "Test",
        "model": key,
        "supply_voltage_V": 12.0,
        "stall_torque_Nm": stall,
        "no_load_speed_rpm": rpm,
        "mass_kg": mass,
        "gear_ratio": 200.0,
        "sources": {
            **SOURCES,
            "gear_ratio": "constructed",
            **{k: "constructed" for k in extra if k != "price_currency"},
        },
        **extra,
    }
    return record_from_mapping(data, "test")


def _brute_force(points_w, points_tau, servos, margin, fraction=CONTINUOUS_FRACTION_OF_STALL):
    """Per joint: every servo checked point by point with the motor's inequalities on the
    scaled point (1 + m)·(ω, τ), then the lightest that passes (None if none)."""
    choices = []
    for j in range(points_w.shape[1]):
        passing = []
        for s in servos:
            stall, w0 = s["stall"], s["w0"]
            d = stall / w0
            ok = True
            for w, tau in zip(points_w[:, j], points_tau[:, j], strict=True):
                wp, tp = (1 + margin) * w, (1 + margin) * tau
                if not (-stall - d * wp <= tp <= stall - d * wp):
                    ok = False
                if abs(tp) > s.get("limit", math.inf):
                    ok = False
            rms = math.sqrt(sum(t * t for t in points_tau[:, j]) / len(points_tau))
            held = min(stall, s.get("limit", math.inf))  # the torque held at rest
            if (1 + margin) * rms > s.get("continuous", fraction * held):
                ok = False
            if ok:
                passing.append((s["mass"], s["key"]))
        choices.append(min(passing)[1] if passing else None)
    return choices


def _constructed_catalogue():
    specs = [
        ("a_small", 0.5, 120.0, 0.02),
        ("b_fast", 1.5, 200.0, 0.06),
        ("c_mid", 3.0, 60.0, 0.08),
        ("d_big", 8.0, 40.0, 0.15),
        ("e_huge", 12.0, 30.0, 0.25),
    ]
    records = {k: _record(k, st, rpm, m) for k, st, rpm, m in specs}
    servos = [
        {"key": k, "stall": st, "w0": rpm * 2 * math.pi / 60, "mass": m} for k, st, rpm, m in specs
    ]
    return records, servos


@pytest.mark.parametrize("seed", range(6))
def test_sizing_matches_a_brute_force_search(seed):
    records, servos = _constructed_catalogue()
    rng = np.random.default_rng(seed)
    n = 5
    scales_tau = np.array([0.05, 0.3, 0.8, 1.5, 20.0])  # the last: no servo holds it
    scales_w = np.array([2.0, 15.0, 4.0, 2.0, 1.0])
    w = rng.uniform(-1, 1, (40, n)) * scales_w
    tau = rng.uniform(-1, 1, (40, n)) * scales_tau
    margin = float(rng.choice([0.0, 0.3, 0.5]))
    fraction = [0.25, 0.5, 1.0][seed % 3]
    sizing = size_joints(
        [f"j{i}" for i in range(n)], w, tau, 1.0, records, margin, continuous_fraction=fraction
    )
    expected = _brute_force(w, tau, servos, margin, fraction)
    assert [j.choice for j in sizing.joints] == expected
    assert expected[-1] is None and sizing.unsized[-1] == "j4"
    assert len({c for c in expected if c is not None}) >= 2  # the search is not trivial


def test_a_set_no_servo_holds_names_its_violations():
    records, _ = _constructed_catalogue()
    tau = np.array([[0.0], [15.0], [-2.0]])
    sizing = size_joints(["knee"], np.zeros_like(tau), tau, 1.0, records, 0.3)
    (joint,) = sizing.joints
    assert joint.choice is None
    closest = joint.to_json()["closest"]
    assert closest["servo"] == "e_huge" and closest["worst_sample"] == 1
    assert any(v.startswith("peak") for v in closest["violations"])


def test_a_published_continuous_rating_replaces_the_assumption():
    light = _record("light", 5.0, 60.0, 0.05, continuous_torque_Nm=0.5)
    heavy = _record("heavy", 5.0, 60.0, 0.10)
    tau = np.full((10, 1), 0.8)  # peaks fine for both; RMS 0.8 > 0.5 but < 0.25 × 5 / 1.3
    sizing = size_joints(["j"], np.zeros_like(tau), tau, 1.0, {"light": light, "heavy": heavy})
    assert sizing.joints[0].choice == "heavy"
    check = sizing.joints[0].check("light")
    assert not check.continuous_assumed and not check.holds_thermal and check.holds_peaks


def _bam(name: str) -> dict:
    return json.loads((BAM_PARAMS_DIR / name / "m1.json").read_text())


def test_envelope_against_the_motor_law_closed_forms():
    catalogue = load_catalogue()
    mx64 = catalogue["mx64"]
    m1 = _bam("mx64")  # BAM's file read here: kt, R
    vin, max_pwm = 15.0, 0.9625  # the record's [firmware] (BAM's firmware table)
    env = envelope(mx64)
    assert env.stall_torque_Nm == pytest.approx(m1["kt"] * vin * max_pwm / m1["R"], rel=1e-12)
    assert env.no_load_speed_rad_s == pytest.approx(vin * max_pwm / m1["kt"], rel=1e-12)
    assert math.isinf(env.torque_limit_Nm)
    # The motor at full duty, spinning at ω: τ = kt (vin·max_pwm − kt ω)/R lies on the boundary.
    motor, firmware = mx64.law("m1")
    for w in (0.0, 2.0, 5.0, -3.0):
        duty = 1e3 if w >= 0 else -1e3  # saturates the duty either way
        tau = float(motor_law.drive(duty, 0.0, w, motor, firmware).torque_Nm)
        assert env.scale(np.array([w]), np.array([tau]))[0] == pytest.approx(1.0, rel=1e-9)
    # A firmware current limit caps |τ| at kt·I_lim (XL330's table sets one).
    xl330 = catalogue["xl330_m288"]
    motor, firmware = xl330.law("m1")
    assert firmware.current_limit_A is not None
    env = envelope(xl330)
    assert env.torque_limit_Nm == pytest.approx(motor.kt_Nm_per_A * firmware.current_limit_A)
    capped = env.torque_limit_Nm
    assert env.scale(np.array([0.0]), np.array([capped / 2]))[0] == pytest.approx(
        min(2.0, 2 * env.stall_torque_Nm / capped)
    )
    # Its boundary is the law the simulation runs at full duty: the current limit at low speed,
    # then the motor line of slope kt²/R (the back-EMF), not a line from the capped torque.
    m1 = _bam("xl330")
    assert env.back_emf_Nms_per_rad == pytest.approx(m1["kt"] ** 2 / m1["R"], rel=1e-12)
    for w in (0.0, 2.0, 8.0, 12.0, 18.0):
        tau = float(motor_law.drive(1e3, 0.0, w, motor, firmware).torque_Nm)
        assert env.scale(np.array([w]), np.array([tau]))[0] == pytest.approx(1.0, rel=1e-9)


def test_datasheet_envelope_is_the_published_line():
    xc = load_catalogue()["xc430_w240"]  # no identified model
    env = envelope(xc)
    assert env.stall_torque_Nm == 1.9 and env.no_load_speed_rad_s == pytest.approx(
        70 * 2 * math.pi / 60
    )
    # Halfway along the line, (ω0/2, τs/2) is on the boundary. Braking at ω0/2 with −τs:
    # s·(−τs) ≥ −τs − (τs/ω0)·s·ω0/2 holds up to s = 2. On τ = −(τs/ω0)·ω (zero volts, the
    # motor shorted) any speed brakes: no bound.
    half = np.array([env.no_load_speed_rad_s / 2])
    assert env.scale(half, np.array([0.95]))[0] == pytest.approx(1.0)
    assert env.scale(half, np.array([-1.9]))[0] == pytest.approx(2.0)
    assert math.isinf(env.scale(half, np.array([-0.95]))[0])


def test_a_figure_changed_in_a_catalogue_copy_changes_the_choice(tmp_path):
    copy = tmp_path / "servos"
    shutil.copytree(SERVOS_DIR, copy, ignore=shutil.ignore_patterns("bam"))
    tau = np.array([[0.2], [-0.25], [0.3]])  # xc430_w240 (65 g, 1.9 N·m) is the lightest fit
    w = np.zeros_like(tau)
    before = size_joints(["j"], w, tau, 1.0, load_catalogue(copy), 0.3).joints[0].choice
    path = copy / "xc430_w240.toml"
    path.write_text(path.read_text().replace("stall_torque_Nm = 1.9", "stall_torque_Nm = 0.9"))
    catalogue = load_catalogue(copy)
    after = size_joints(["j"], w, tau, 1.0, catalogue, 0.3).joints[0].choice
    assert before == "xc430_w240"
    # Now 0.25 × 0.9 N·m < 1.3 × RMS 0.25 N·m: the next lightest that holds, found by brute force.
    servos = [
        {"key": r.key, "stall": envelope(r).stall_torque_Nm,
         "w0": envelope(r).no_load_speed_rad_s, "mass": r.mass_kg,
         "limit": envelope(r).torque_limit_Nm}
        for r in catalogue.values()
    ]  # fmt: skip
    assert after == _brute_force(w, tau, servos, 0.3)[0] != "xc430_w240"


@pytest.mark.parametrize(
    ("margin", "w", "tau", "words"),
    [
        (float("nan"), np.zeros((3, 1)), np.ones((3, 1)), "margin"),
        (-0.1, np.zeros((3, 1)), np.ones((3, 1)), "margin"),
        (0.3, np.zeros((0, 1)), np.zeros((0, 1)), "no torque"),
        (0.3, np.zeros((3, 1)), np.full((3, 1), np.nan), "NaN"),
        (0.3, np.zeros((3, 2)), np.ones((3, 2)), "expected"),
    ],
)
def test_hostile_inputs_are_one_clear_error(margin, w, tau, words):
    records, _ = _constructed_catalogue()
    with pytest.raises(SizingError, match=words):
        size_joints(["j"], w, tau, 1.0, records, margin)


@pytest.mark.parametrize("fraction", [0.0, -0.5, 1.5, float("nan")])
def test_a_bad_continuous_fraction_is_one_clear_error(fraction):
    records, _ = _constructed_catalogue()
    with pytest.raises(SizingError, match="continuous fraction"):
        size_joints(["j"], np.zeros((2, 1)), np.ones((2, 1)), 1.0, records,
                    continuous_fraction=fraction)  # fmt: skip


def test_sizing_by_price_leaves_out_servos_without_one():
    records, _ = _constructed_catalogue()
    priced = _record("priced", 20.0, 100.0, 1.0, price=10.0, price_currency="USD")
    records = {**records, "priced": priced}
    tau = np.full((4, 1), 0.05)  # a_small holds it and is lighter; only `priced` has a price
    by_mass = size_joints(["j"], np.zeros_like(tau), tau, 1.0, records, by="mass")
    by_price = size_joints(["j"], np.zeros_like(tau), tau, 1.0, records, by="price")
    assert by_mass.joints[0].choice == "a_small" and by_price.joints[0].choice == "priced"
    assert any("without a price" in note for note in by_price.notes)


@pytest.mark.parametrize("seed", range(4))
def test_several_motions_need_a_servo_that_holds_every_one(seed):
    from app.core.servo.sizing import combine

    records, servos = _constructed_catalogue()
    rng = np.random.default_rng(100 + seed)
    names = [f"j{i}" for i in range(4)]
    works = {}
    for label, scale in (("squat", [0.05, 0.4, 1.0, 2.0]), ("gait", [0.3, 0.05, 1.5, 0.5])):
        w = rng.uniform(-1, 1, (30, 4)) * 3.0
        tau = rng.uniform(-1, 1, (30, 4)) * np.array(scale)
        works[label] = (w, tau)
    sizing = combine(
        {k: size_joints(names, w, tau, 1.0, records, 0.3) for k, (w, tau) in works.items()},
        records,
    )
    expected = []
    for j in range(4):
        passing = [
            (s["mass"], s["key"])
            for s in servos
            if all(
                _brute_force(w[:, [j]], tau[:, [j]], [s], 0.3)[0] is not None
                for w, tau in works.values()
            )
        ]
        expected.append(min(passing)[1] if passing else None)
    assert [joint.choice for joint in sizing.joints] == expected
    singles = [size_joints(names, w, tau, 1.0, records, 0.3) for w, tau in works.values()]
    # Holding both is never lighter than holding either alone.
    masses = {k: r.mass_kg for k, r in records.items()}
    for j, joint in enumerate(sizing.joints):
        for single in singles:
            alone = single.joints[j].choice
            if joint.choice is not None:
                assert alone is not None and masses[alone] <= masses[joint.choice]
