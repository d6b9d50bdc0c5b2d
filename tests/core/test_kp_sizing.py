"""Sizing chooses kp: checked against the stand check's linearised balance (an independent
module), the motor law's closed form K = kt·vin·error_gain·kp/R written here, and MuJoCo: on a
constructed servo whose one kp step is a large change of stiffness, servo_biped stands still on
the chosen kp and falls one step below it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from app.core.dynamics.stand_stiffness import stand_check
from app.core.motions.trajectory import Trajectory
from app.core.servo.catalogue import record_from_mapping
from app.core.servo.kp_sizing import size_with_kp
from app.core.servo.model import joint_angles
from app.core.servo.parts import parts_from_mapping
from app.core.servo.sized_parts import sized_parts
from app.core.servo.sizing import SizingError
from app.core.servo.sizing_work import Work
from app.core.simulation.part_law import part_servo_law
from app.core.simulation.run import simulate_commands

KT, R, VIN = 1.0, 2.0, 12.0
SOURCED = (
    "supply_voltage_V",
    "stall_torque_Nm",
    "no_load_speed_rpm",
    "mass_kg",
    "gear_ratio",
    "firmware",
    "motor",
    "kp_max",
)


def _servo(key: str, per_kp: float, kp_max: float, mass: float = 0.1, friction: float = 0.0):
    """A constructed servo whose K is `per_kp` N·m/rad per unit of kp (error_gain set so)."""
    return record_from_mapping(
        {
            "key": key,
            "maker": "Test",
            "model": key,
            "supply_voltage_V": VIN,
            "stall_torque_Nm": KT * VIN / R,
            "no_load_speed_rpm": VIN / KT * 60 / (2 * math.pi),
            "mass_kg": mass,
            "gear_ratio": 200.0,
            "firmware": {
                "vin_V": VIN,
                "kp": 1,
                "error_gain": per_kp * R / (KT * VIN),
                "max_pwm": 1.0,
                "kp_max": kp_max,
            },
            "motor": {
                "kt_Nm_per_A": KT,
                "R_ohm": R,
                "armature_kgm2": 0.005,
                "friction_base_Nm": friction,
            },
            "sources": {name: "constructed for the test" for name in SOURCED},
        },
        "test",
    )


@pytest.fixture(scope="module")
def standing(servo_biped, com_shift):
    """servo_biped standing still for 3 s at com_shift's first pose, and K* [N·m/rad]: every
    leg servo at 1/K* is where the stand check's balance turns."""
    robot, q0, T = servo_biped, com_shift.q[0], 300
    traj = Trajectory(
        "stand",
        tuple(robot.joint_names),
        np.arange(T) * 0.01,
        np.repeat(q0[None], T, axis=0),
        np.zeros((T, robot.model.nv)),
        np.zeros((T, robot.model.nv)),
        np.ones((T, 2), dtype=bool),
    )
    check = stand_check(robot, q0, np.zeros(robot.n_actuated))
    return traj, 1.0 / math.radians(check.max_leg_compliance_deg_per_Nm)


def _still(robot, traj) -> dict[str, Work]:
    n = robot.n_actuated
    return {
        "stand": Work(
            np.zeros((traj.n_samples, n)), np.zeros((traj.n_samples, n)), np.arange(traj.n_samples)
        )
    }


def _kps(sizing) -> list[float | None]:
    return [None if j.choice is None else j.check(j.choice).stiffness.kp for j in sizing.joints]


def test_one_kp_step_below_the_chosen_falls_in_mujoco_and_the_chosen_stands(servo_biped, standing):
    robot = servo_biped
    traj, k_star = standing
    record = _servo("stiff", k_star / 2.6, 100)  # kp 3 ≈ 1.15 K*, kp 2 ≈ 0.77 K*
    sizing = size_with_kp(
        robot, _still(robot, traj), traj.duration, {"stiff": record}, trajectory=traj,
        stand_margin=0.0, max_sag_deg=90.0,
    )  # fmt: skip
    assert _kps(sizing) == [3.0] * 12  # the smallest whole kp with K ≥ K*: ceil(2.6)
    verdicts = {}
    for kp in (3, 2):
        parts = parts_from_mapping(
            {"servo": "stiff", "kp": kp, "dead_band_deg": 0},
            robot.joint_names,
            {"stiff": record},
            "t",
        )
        assert parts.parts[0].stiffness_Nm_per_rad == pytest.approx(
            KT * VIN * record.firmware.error_gain * kp / R
        )
        check = stand_check(robot, traj.q[0], parts.servo_model().compliance_deg_per_Nm)
        (result,) = simulate_commands(
            robot, traj, {"plan": joint_angles(robot, traj.q)}, parts.servo_model(),
            parallel=False, law=part_servo_law(parts),
        ).values()  # fmt: skip
        verdicts[kp] = (check.stands, result.outcome.kind)
    assert verdicts[3] == (True, "stays up")
    assert verdicts[2][0] is False and verdicts[2][1] in ("falls", "leans")


def test_with_the_stand_margin_the_chosen_kp_stands_softened_and_one_step_below_does_not(
    servo_biped, standing
):
    robot = servo_biped
    traj, k_star = standing
    per_kp = k_star / 7.3
    sizing = size_with_kp(
        robot, _still(robot, traj), traj.duration, {"s": _servo("s", per_kp, 254)},
        trajectory=traj, stand_margin=0.5, max_sag_deg=90.0,
    )  # fmt: skip
    (kp,) = set(_kps(sizing))
    assert kp == math.ceil(1.5 * 7.3)
    for step, stands in ((kp, True), (kp - 1, False)):  # every leg servo 1.5× softer
        compliance = np.full(12, math.degrees(1.5 / (per_kp * step)))
        assert stand_check(robot, traj.q[0], compliance).stands is stands


def test_the_sag_bound_sets_kp_where_the_load_needs_more_than_standing(servo_biped, standing):
    robot = servo_biped
    traj, k_star = standing
    work = _still(robot, traj)["stand"]
    tau = work.torque_Nm.copy()
    tau[::7, 3] = 2.0  # the left knee loaded: 2 N·m + 0.1 N·m friction within 3° needs K ≥ 40
    sizing = size_with_kp(
        robot, {"load": Work(work.speed_rad_s, tau, work.sample_index)}, traj.duration,
        {"s": _servo("s", 1.0, 254, friction=0.1)}, trajectory=traj, max_sag_deg=3.0,
    )  # fmt: skip
    kps = _kps(sizing)
    assert kps[3] == math.ceil(2.1 / math.radians(3.0))
    assert kps[0] == math.ceil(1.5 * k_star)  # the others: standing sets it
    knee = sizing.joints[3].check("s").stiffness
    assert knee.sag_deg <= 3.0 < math.degrees(2.1 / (kps[3] - 1))


def test_a_servo_whose_range_is_too_soft_gives_way_to_the_next_and_none_is_said(
    servo_biped, standing
):
    robot = servo_biped
    traj, k_star = standing
    soft = _servo("soft", k_star / 100, 100, mass=0.05)  # kp ≤ 100 reaches K*, not 1.5 K*
    stiff = _servo("stiff", k_star / 10.5, 100, mass=0.2)  # kp 16
    both = size_with_kp(
        robot, _still(robot, traj), traj.duration, {"soft": soft, "stiff": stiff}, trajectory=traj
    )
    assert [j.choice for j in both.joints] == ["stiff"] * 12
    assert _kps(both) == [16.0] * 12
    alone = size_with_kp(robot, _still(robot, traj), traj.duration, {"soft": soft}, trajectory=traj)
    assert alone.unsized == tuple(robot.joint_names)
    (violation,) = alone.joints[4].check("soft").violations()
    assert violation.startswith("stiffness: needs K ≥") and "kp ≤ 100" in violation


def test_the_servo_toml_carries_each_joints_kp_and_a_kp_for_all_overrides_it(servo_biped, standing):
    import tomllib

    robot = servo_biped
    traj, k_star = standing
    record = _servo("stiff", k_star / 2.6, 100)
    sizing = size_with_kp(
        robot, _still(robot, traj), traj.duration, {"stiff": record}, trajectory=traj,
        stand_margin=0.0,
    )  # fmt: skip
    own = sized_parts(sizing)
    assert tomllib.loads(own.text)["joints"]["left_knee"] == {"servo": "stiff", "kp": 3}
    assert own.softer == ()
    override = sized_parts(sizing, 2.0)
    data = tomllib.loads(override.text)
    assert data["kp"] == 2 and data["joints"]["left_knee"] == {"servo": "stiff"}
    assert override.softer == tuple(robot.joint_names)  # softer than standing needs
    with pytest.raises(SizingError, match="outside stiff's firmware range 0 … 100"):
        sized_parts(sizing, 101.0)


@pytest.mark.parametrize(
    ("options", "words"),
    [
        ({"stand_margin": -0.1}, "stand margin is -0.1"),
        ({"stand_margin": float("nan")}, "stand margin is nan"),
        ({"max_sag_deg": 0.0}, "max sag is 0°"),
        ({"stand_margin": 11.0}, r"stand margin is 11; give a number in \[0, 10\]"),
        ({"max_sag_deg": float("inf")}, "max sag is inf"),
    ],
)
def test_bad_stiffness_options_are_one_line(servo_biped, standing, options, words):
    traj, k_star = standing
    with pytest.raises(SizingError, match=words):
        size_with_kp(
            servo_biped, _still(servo_biped, traj), 1.0, {"s": _servo("s", k_star, 10)},
            trajectory=traj, **options,
        )  # fmt: skip


def _bam(key: str, fit: str) -> dict:
    """BAM's fit file of `key` (robots/servos/bam, a copy of ../shared/actuators/bam) and the
    firmware table of its record's TOML, as the files say."""
    import json
    import tomllib

    from app.core.servo.catalogue import BAM_PARAMS_DIR, SERVOS_DIR

    firmware = tomllib.loads((SERVOS_DIR / f"{key}.toml").read_text())["firmware"]
    return {**json.loads((BAM_PARAMS_DIR / key / f"{fit}.json").read_text()), **firmware}


def _at_rest_friction_Nm(fit: dict, load_Nm: float) -> float:
    """The fit's friction at rest holding `load_Nm` (the motor torque opposing it): m1's
    friction_base; m6's budget with s = 1 (q̇ = 0), BAM's m6 terms written out."""
    if fit["model"] == "m1":
        return fit["friction_base"]
    return (
        fit["friction_base"]
        + fit["friction_stribeck"]
        + load_Nm * (fit["load_friction_external"] + fit["load_friction_motor"])
        + load_Nm * (fit["load_friction_external_stribeck"] + fit["load_friction_motor_stribeck"])
    )


def test_the_kp_rule_uses_the_fit_the_joints_part_runs(servo_biped, standing):
    """An MX-64 sized on m6 (as a servo.toml or project asks) takes K = kt·vin·error_gain·kp/R
    with the m6 file's kt and R (1.7× the m1 fit's per kp) and m6's friction at rest under
    the load: per joint the smallest whole kp with K ≥ max((1 + margin)·K* on a leg joint,
    (|τ| + friction) / max sag), as the closed forms give it from the files' numbers; the
    servo.toml written runs m6 with that K."""
    import tomllib

    from app.core.servo.catalogue import load_catalogue
    from app.core.servo.motor_law import FrictionM6

    robot = servo_biped
    traj, k_star = standing
    legs = set(stand_check(robot, traj.q[0], np.zeros(robot.n_actuated)).leg_joints)
    work = _still(robot, traj)["stand"]
    tau = work.torque_Nm.copy()
    knees = [j for j, name in enumerate(robot.joint_names) if "knee" in name]
    tau[:, knees] = 0.8  # the sag bound sets the knees' kp, m6's load friction with it
    works = {"load": Work(work.speed_rad_s, tau, work.sample_index)}
    record = load_catalogue()["mx64"]
    kps = {}
    for name in ("m1", "m6"):
        fit = _bam("mx64", name)
        per_kp = fit["kt"] * fit["vin_V"] * fit["error_gain"] / fit["R"]
        sizing = size_with_kp(
            robot, works, traj.duration, {"mx64": record}, trajectory=traj,
            fits={joint: name for joint in robot.joint_names},
        )  # fmt: skip
        kps[name] = _kps(sizing)
        for j, joint in enumerate(sizing.joints):
            load = float(np.abs(tau[:, j]).max())
            need = max(
                1.5 * k_star if j in legs else 0.0,
                (load + _at_rest_friction_Nm(fit, load)) / math.radians(2.0),
            )
            grid = np.arange(1, fit["kp_max"] + 1, dtype=float)
            chosen = joint.check("mx64").stiffness
            assert chosen.fit == name
            assert chosen.per_kp_Nm_per_rad == pytest.approx(per_kp, rel=1e-12)
            assert chosen.kp == grid[grid * per_kp >= need][0], joint.joint
        if name == "m6":
            data = tomllib.loads(sized_parts(sizing).text)
            assert data["joints"]["left_knee"]["friction_model"] == "m6"
            parts = parts_from_mapping(data, robot.joint_names, {"mx64": record}, "sized")
            for part, kp in zip(parts.parts, kps["m6"], strict=True):
                assert isinstance(part.friction, FrictionM6)
                assert part.stiffness_Nm_per_rad == pytest.approx(kp * per_kp, rel=1e-12)
    assert kps["m6"] != kps["m1"]  # the fits differ enough for the rule to tell them apart
    assert all(a < b for a, b in zip(kps["m6"], kps["m1"], strict=True) if a != b)


def test_a_servo_without_an_m6_fit_is_sized_on_its_m1_and_said(servo_biped, standing):
    robot = servo_biped
    traj, k_star = standing
    record = _servo("own", k_star / 10, 254)  # the user's own m1 fit only
    assert record.fit("m6") is None
    sizing = size_with_kp(
        robot, _still(robot, traj), traj.duration, {"own": record}, trajectory=traj,
        fits={robot.joint_names[0]: "m6"},
    )  # fmt: skip
    assert {j.check("own").stiffness.fit for j in sizing.joints} == {"m1"}
    assert "no m6 fit: own sized on m1 where m6 was asked" in sizing.notes
    with pytest.raises(SizingError, match="friction model 'm9'"):
        size_with_kp(
            robot, _still(robot, traj), traj.duration, {"own": record}, trajectory=traj,
            fits={robot.joint_names[0]: "m9"},
        )  # fmt: skip
