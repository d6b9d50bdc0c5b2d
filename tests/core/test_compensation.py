"""Spring and clearance compensation (paper eq 7, eq 23), presets and the servo numbering."""

from __future__ import annotations

import dataclasses
import io
import math

import numpy as np
import pinocchio as pin
import pytest

from app.core.robot.loading import load_robot
from app.core.servo.compensation import (
    CompensationError,
    CompensationParams,
    compensated_command,
    disabled_params,
    k_rad_per_Nm,
)
from app.core.servo.files import read_coefficients_toml, read_torque_csv
from app.core.servo.presets import paper_table2_preset, paper_table3_preset, servo_joint_names
from tests.conftest import ROBAN_URDF

D = math.radians


def params(k, phi=None, enabled=None, sign="command", names=None):
    n = len(k)
    return CompensationParams(
        tuple(names or (f"j{i}" for i in range(n))),
        np.array(k, dtype=float),
        np.zeros(n) if phi is None else np.array(phi, dtype=float),
        np.ones(n, bool) if enabled is None else np.array(enabled),
        sign,
    )


def test_k_conversion():
    assert k_rad_per_Nm(180.0 / math.pi) == pytest.approx(1.0)
    assert k_rad_per_Nm(np.array([1.0, -650.0])) == pytest.approx([D(1.0), D(-650.0)])


def test_eq7_by_hand():
    # q = 10°, −20°; τ = 0.5, −2 N·m; k = 2, −3 °/(N·m): q_des = 10 + 1 = 11°, −20 + 6 = −14°.
    q = np.array([[D(10.0), D(-20.0)]])
    tau = np.array([[0.5, -2.0]])
    out = compensated_command(q, tau, params([2.0, -3.0]))
    assert out == pytest.approx(np.array([[D(11.0), D(-14.0)]]), abs=1e-15)


def test_eq7_zero_torque_and_disabled_joint_leave_the_plan():
    q = np.array([[0.3, -0.2], [0.1, 0.4]])
    tau = np.array([[0.0, 5.0], [0.0, -5.0]])
    out = compensated_command(q, tau, params([100.0, 100.0], phi=[0.0, 8.0], enabled=[True, False]))
    assert np.array_equal(out, q)


@pytest.mark.parametrize(
    "q_deg, tau, k, sign, expected_deg",
    [
        # q + kτ = −5 + 2 = −3° < 0: paper rule subtracts φ; τ > 0: torque rule adds it.
        (-5.0, 1.0, 2.0, "command", -3.0 - 8.0),
        (-5.0, 1.0, 2.0, "torque", -3.0 + 8.0),
        # q + kτ = −1 + 4·0.5 = 1° > 0 and τ > 0: both rules add φ.
        (-1.0, 0.5, 4.0, "command", 9.0),
        (-1.0, 0.5, 4.0, "torque", 9.0),
        # q + kτ = 10 − 2·3 = 4° > 0, τ = 3 > 0 but k < 0.
        (10.0, 3.0, -2.0, "command", 12.0),
        (10.0, -3.0, 2.0, "torque", 4.0 - 8.0),
        # q + kτ exactly 0: eq 23 has no case for it, nothing is added.
        (-2.0, 1.0, 2.0, "command", 0.0),
        # τ = 0: the torque rule adds nothing, the paper's rule still adds φ·sign(q).
        (3.0, 0.0, 2.0, "torque", 3.0),
        (3.0, 0.0, 2.0, "command", 11.0),
    ],
)
def test_eq23_by_hand(q_deg, tau, k, sign, expected_deg):
    out = compensated_command(
        np.array([[D(q_deg)]]), np.array([[tau]]), params([k], phi=[8.0], sign=sign)
    )
    assert out[0, 0] == pytest.approx(D(expected_deg), abs=1e-14)


def test_vectorised_over_samples_matches_row_by_row():
    rng = np.random.default_rng(3)
    q, tau = rng.normal(size=(50, 4)), rng.normal(size=(50, 4))
    p = params([3.0, -7.0, 0.5, 20.0], phi=[0.0, 8.0, 2.0, 1.0], enabled=[1, 1, 0, 1])
    whole = compensated_command(q, tau, p)
    for t in range(50):
        assert np.array_equal(compensated_command(q[t : t + 1], tau[t : t + 1], p)[0], whole[t])


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"k": [float("nan")]}, "k of j0 is nan"),
        ({"k": [1e6]}, "within ±5000"),
        ({"k": [1.0], "phi": [-1.0]}, "φ of j0"),
        ({"k": [1.0], "phi": [90.0]}, "between 0 and 45"),
        ({"k": [1.0], "sign": "angle"}, "'command'"),
    ],
)
def test_invalid_params_are_refused(kwargs, message):
    with pytest.raises(CompensationError, match=message):
        params(**kwargs)


def test_shape_mismatches_are_refused():
    with pytest.raises(CompensationError, match="2 value"):
        CompensationParams(("a",), np.zeros(2), np.zeros(1), np.ones(1, bool))
    with pytest.raises(CompensationError, match="more than once"):
        CompensationParams(("a", "a"), np.zeros(2), np.zeros(2), np.ones(2, bool))
    p = params([1.0, 2.0])
    with pytest.raises(CompensationError, match=r"expected \(T, 2\)"):
        compensated_command(np.zeros((5, 3)), np.zeros((5, 3)), p)
    with pytest.raises(CompensationError, match="torques have shape"):
        compensated_command(np.zeros((5, 2)), np.zeros((4, 2)), p)
    tau = np.zeros((5, 2))
    tau[3, 1] = np.nan
    with pytest.raises(CompensationError, match="sample 3, joint j1"):
        compensated_command(np.zeros((5, 2)), tau, p)


def test_for_joints_reorders_and_refuses_unknown_names(servo_biped):
    p = params([2.0, -4.0], phi=[1.0, 8.0], names=("right_knee", "left_hip_roll"))
    laid = p.for_joints(servo_biped.joint_names)
    assert laid.joint_names == servo_biped.joint_names
    assert laid.k_deg_per_Nm[servo_biped.joint_names.index("right_knee")] == 2.0
    assert laid.k_deg_per_Nm[servo_biped.joint_names.index("left_hip_roll")] == -4.0
    assert laid.enabled.sum() == 2
    with pytest.raises(CompensationError, match=r"no joint named 'left_hip_rol'.*left_hip_yaw"):
        params([1.0], names=("left_hip_rol",)).for_joints(servo_biped.joint_names)


def test_for_joints_keeps_the_other_fields_and_gives_unnamed_joints_nothing(servo_biped):
    p = dataclasses.replace(
        params([2.0, -4.0], phi=[1.0, 8.0], sign="torque", names=("right_knee", "left_hip_roll")),
        notes=("from a file",),
    )
    laid = p.for_joints(servo_biped.joint_names)
    assert (laid.clearance_sign, laid.notes) == ("torque", ("from a file",))
    by_name = {"right_knee": (2.0, 1.0), "left_hip_roll": (-4.0, 8.0)}  # the record, by name
    for j, name in enumerate(servo_biped.joint_names):
        k, phi = by_name.get(name, (0.0, 0.0))
        assert (laid.k_deg_per_Nm[j], laid.phi_deg[j], laid.enabled[j]) == (k, phi, name in by_name)
    assert laid.enabled.dtype == bool
    assert p.for_joints(p.joint_names) is p  # already laid out: the same record


def test_params_are_read_only():
    p = params([1.0])
    with pytest.raises(ValueError):
        p.k_deg_per_Nm[0] = 5.0


# --- servo numbering and the paper's presets ------------------------------------------------


def test_servo_numbering_on_servo_biped_is_its_joint_order(servo_biped):
    assert servo_joint_names(servo_biped) == servo_biped.joint_names


def test_table2_standing_pose_fits_the_numbering(servo_biped):
    """Table 2's q_des, put on the joints our numbering gives, is a flat-footed stand: hip
    pitch + knee + ankle pitch ≈ 0 and hip roll + ankle roll ≈ 0 on each leg, knees bent
    69° (servos 4, 10). Checked with pinocchio's FK: each sole parallel to the pelvis."""
    from app.core.servo.calibration import table2_rows

    q_des = {row.servo: row.q_des_deg for row in table2_rows()}
    names = servo_joint_names(servo_biped)
    q = servo_biped.with_joint_angles(
        servo_biped.q_neutral,
        np.array([D(q_des[names.index(name) + 1]) for name in servo_biped.joint_names]),
    )
    data = servo_biped.model.createData()
    placements = servo_biped.link_placements(q, data)
    for foot in servo_biped.feet:
        R_base_foot = placements["base"][:3, :3].T @ placements[foot.link][:3, :3]
        assert np.degrees(np.abs(pin.rpy.matrixToRpy(R_base_foot))).max() < 0.02
    assert servo_biped.joint_angles(q)[[3, 9]] == pytest.approx([D(68.7407), D(68.7484)])


def test_table3_preset_on_servo_biped(servo_biped):
    p = paper_table3_preset(servo_biped)
    k = dict(zip(p.joint_names, p.k_deg_per_Nm, strict=True))
    on = {name for name, e in zip(p.joint_names, p.enabled, strict=True) if e}
    assert on == {"left_hip_roll", "left_hip_pitch", "right_hip_roll", "right_hip_pitch"}
    assert (k["left_hip_roll"], k["left_hip_pitch"]) == (-4.0, -650.0)
    assert (k["right_hip_roll"], k["right_hip_pitch"]) == (20.0, -1200.0)
    assert not p.phi_deg.any()
    clearance = paper_table3_preset(servo_biped, clearance=True)
    assert set(clearance.phi_deg[clearance.enabled]) == {8.0}
    assert not clearance.phi_deg[~clearance.enabled].any()
    assert clearance.clearance_sign == "command"


def test_table2_preset_corrects_servo_11(servo_biped):
    p = paper_table2_preset(servo_biped)
    k = dict(zip(p.joint_names, p.k_deg_per_Nm, strict=True))
    assert p.enabled.all()
    assert k["right_ankle_pitch"] == pytest.approx((-30.8266 + 29.375) / 0.02008)  # servo 11
    assert k["left_hip_roll"] == -1.28 and k["right_knee"] == -1.41
    assert any("servo 11" in note and "-722.91" in note for note in p.notes)


def test_servo_numbering_on_roban_s14_follows_axes_not_position():
    """Roban S14's legs hang below a waist joint and start with a 45°-tilted hip joint; Leju
    names its meshes l_leg_pitch, l_leg_roll, l_leg_yaw for links l1, l2, l3."""
    roban = load_robot(str(ROBAN_URDF))
    names = servo_joint_names(roban)
    assert names[:6] == (
        "leg_l3_joint",
        "leg_l2_joint",
        "leg_l1_joint",
        "leg_l4_joint",
        "leg_l5_joint",
        "leg_l6_joint",
    )
    assert names[6:] == tuple(name.replace("_l", "_r") for name in names[:6])
    p = paper_table3_preset(roban)
    assert p.joint_names == roban.joint_names
    assert p.k_deg_per_Nm[roban.joint_names.index("leg_r1_joint")] == -1200.0


@pytest.mark.parametrize("name, count", [("dircon_biped", 5), ("hybrid_leg_biped", 4)])
def test_presets_need_six_joint_legs(name, count):
    robot = load_robot(name)
    with pytest.raises(CompensationError, match=f"6 actuated joints per leg.*has {count}"):
        paper_table3_preset(robot)


# --- k.toml ---------------------------------------------------------------------------------


def test_read_coefficients_toml_round_trip(servo_biped):
    text = b"""
clearance_sign = "torque"
[joints.left_hip_roll]
k_deg_per_Nm = -4
phi_deg = 8.0
[joints.right_knee]
k_deg_per_Nm = 1.5
enabled = false
"""
    p = read_coefficients_toml(io.BytesIO(text))
    assert p.joint_names == ("left_hip_roll", "right_knee")
    assert list(p.k_deg_per_Nm) == [-4.0, 1.5] and list(p.phi_deg) == [8.0, 0.0]
    assert list(p.enabled) == [True, False] and p.clearance_sign == "torque"
    again = read_coefficients_toml(io.BytesIO(p.to_toml().encode()))
    assert np.array_equal(again.k_deg_per_Nm, p.k_deg_per_Nm)
    assert np.array_equal(again.enabled, p.enabled)
    table3 = paper_table3_preset(servo_biped, clearance=True)
    back = read_coefficients_toml(io.BytesIO(table3.to_toml().encode()))
    assert np.array_equal(back.k_deg_per_Nm, table3.k_deg_per_Nm)
    assert np.array_equal(back.phi_deg, table3.phi_deg)


@pytest.mark.parametrize(
    "text, message",
    [
        (b"[joints.a]\nk = 1\n", "unknown key"),
        (b"[joints.a]\nphi_deg = 1\n", "has no k_deg_per_Nm"),
        (b'[joints.a]\nk_deg_per_Nm = "x"\n', "must be a number"),
        (b"[joints.a]\nk_deg_per_Nm = nan\n", "joints.a.k_deg_per_Nm is nan"),
        (b"[joints.a]\nk_deg_per_Nm = 1\nenabled = 1\n", "true or false"),
        (b"k_deg_per_Nm = 1\n", "unknown key"),
        (b"", "no \\[joints"),
        (b"[joints.a\n", "not valid TOML"),
    ],
)
def test_bad_toml_is_refused_clearly(text, message):
    with pytest.raises(CompensationError, match=message):
        read_coefficients_toml(io.BytesIO(text))


def test_disabled_params_pass_the_plan_through():
    q = np.random.default_rng(0).normal(size=(4, 3))
    assert np.array_equal(compensated_command(q, q * 10, disabled_params(("a", "b", "c"))), q)


# --- torque feed-forward CSV ----------------------------------------------------------------


def test_read_torque_csv_by_column_names():
    text = "status,tau:b [N·m],t [s],tau:a [N·m]\nok,2.5,0.0,-1\nmax_iter,3,0.01,-2\n"
    table = read_torque_csv(io.StringIO(text), ("a", "b"))
    assert table.t.tolist() == [0.0, 0.01]
    assert table.tau_Nm.tolist() == [[-1.0, 2.5], [-2.0, 3.0]]
    assert table.status == ("ok", "max_iter")


@pytest.mark.parametrize(
    "text, message",
    [
        ("", "empty file"),
        ("tau:a [N·m]\n1\n", r"no 't \[s\]' column"),
        ("t [s],tau:a [rad]\n0,1\n", "must be in N·m"),
        ("t [s],tau:a [N·m]\n0,1\n", "no tau:<joint> column for b"),
        (
            "t [s],tau:a [N·m],tau:b [N·m],tau:c [N·m]\n0,1,2,3\n",
            "no joint named 'c' on this robot",
        ),
        ("t [s],tau:a [N·m],tau:b [N·m]\n0,1,2\n0.1,x,2\n", "line 3: tau:a \\[N·m\\] 'x'"),
        ("t [s],tau:a [N·m],tau:b [N·m]\n0,1,nan\n", "line 2: tau:b \\[N·m\\] is 'nan'"),
        ("t [s],tau:a [N·m],tau:b [N·m]\n", "no samples"),
    ],
)
def test_bad_torque_csv_is_refused_clearly(text, message):
    with pytest.raises(CompensationError, match=message):
        read_torque_csv(io.StringIO(text), ("a", "b"))
