"""Calibrating k from measurements (paper section 4.4), checked against the paper's Table 2."""

from __future__ import annotations

import io
import math

import numpy as np
import pytest

from app.core.servo.calibration import (
    ENCODER_RESOLUTION_DEG,
    CalibrationError,
    calibrate,
    check_table2,
    read_measured_csv,
    table2_rows,
)

HEADER = "frame,joint,q_cmd_deg,q_meas_deg,tau_Nm\n"
# Table 2 as printed in the paper, typed in again here (servo, q_des, q, τ, k).
PAPER_TABLE2 = [
    (1, -0.00026, -0.23438, -0.00197, -118.74),
    (2, 0.6226, 0.15625, -0.36474, -1.28),
    (3, -37.9075, -36.6406, 0.01779, -71.21),
    (4, 68.7407, 71.6406, -1.86625, 1.55),
    (5, -30.8239, -28.9844, 0.00371, -495.82),
    (6, -0.6245, -1.40625, 0.01724, 45.36),
    (7, 0.00017, 0.23438, 0.00198, -118.29),
    (8, -0.60888, -0.46874, -0.39568, 0.35),
    (9, -37.9126, -37.1875, -0.004, 181.28),
    (10, 68.7484, 71.4062, 1.88342, -1.41),
    (11, -30.8266, -29.375, 0.02008, -722.91),
    (12, 0.60647, 1.0156, -0.01592, 25.70),
]


def table2_csv(scales=(1.0,)) -> str:
    """One frame per scale: frame s holds every servo with τ and q_des − q scaled by s (exact
    data on the line through the origin that the row defines)."""
    lines = [HEADER]
    for frame, s in enumerate(scales):
        for servo, q_des, q, tau, _ in PAPER_TABLE2:
            lines.append(f"{frame},servo{servo},{q + s * (q_des - q)!r},{q!r},{s * tau!r}\n")
    return "".join(lines)


def by_joint(calibrations):
    return {c.joint: c for c in calibrations}


def test_table2_rows_are_the_paper_table():
    rows = table2_rows()
    assert [(r.servo, r.q_des_deg, r.q_deg, r.tau_Nm, r.k_printed) for r in rows] == PAPER_TABLE2


def test_check_table2_flags_only_servo_11():
    checks = {c.servo: c for c in check_table2()}
    assert [s for s, c in checks.items() if not c.agrees] == [11]
    assert checks[11].k_computed == pytest.approx(-72.29, abs=0.005)
    assert checks[11].k_printed / checks[11].k_computed == pytest.approx(10.0, rel=1e-3)
    assert "10.00 ×" in checks[11].note
    # Rows 1 and 6 differ from their printed k in the 4th digit, inside the rounding of τ.
    assert checks[1].k_computed == pytest.approx(-118.84, abs=0.01)
    assert checks[1].k_low <= -118.74 <= checks[1].k_high
    assert checks[6].k_computed == pytest.approx(45.345, abs=0.001)


def test_measured_angles_are_whole_encoder_steps():
    """The resolution we assume is what Table 2's measured q column shows."""
    steps = np.array([q for _, _, q, _, _ in PAPER_TABLE2]) / ENCODER_RESOLUTION_DEG
    assert np.abs(steps - np.round(steps)).max() < 2e-3


def test_calibration_reproduces_table2_k_column():
    result = by_joint(calibrate(read_measured_csv(io.StringIO(table2_csv()))))
    for servo, q_des, q, tau, k_printed in PAPER_TABLE2:
        c = result[f"servo{servo}"]
        assert c.n_frames == 1
        assert c.k_deg_per_Nm == pytest.approx((q_des - q) / tau, rel=1e-12)
        if servo != 11:
            # The printed k, to its printed digits (rows 1 and 6 to the rounding of τ).
            assert c.k_deg_per_Nm == pytest.approx(k_printed, rel=1e-3, abs=0.005)
        assert math.isnan(c.se_deg_per_Nm)
    assert result["servo11"].k_deg_per_Nm == pytest.approx(-72.29, abs=0.005)
    assert result["servo11"].k_deg_per_Nm != pytest.approx(-722.91, rel=0.5)


def test_exact_data_over_several_frames_has_zero_standard_error():
    result = calibrate(read_measured_csv(io.StringIO(table2_csv(scales=(0.5, 1.0, 2.0, 3.0)))))
    for c, (_, q_des, q, tau, _) in zip(result, PAPER_TABLE2, strict=True):
        k = (q_des - q) / tau
        assert c.n_frames == 4
        assert c.k_deg_per_Nm == pytest.approx(k, rel=1e-9)
        assert c.se_deg_per_Nm <= 1e-9 * abs(k)
        assert c.k_with_offset_deg_per_Nm == pytest.approx(k, rel=1e-6)
        assert c.offset_deg == pytest.approx(0.0, abs=1e-6)


def test_identifiability_of_table2_servos():
    """Only the knees (4, 10) and left hip roll (2) carry enough torque and deflection; the
    other standing torques are 0.02 N·m or less, and servo 8's 0.14° deflection is under two
    encoder steps. The paper retuned 2, 3, 8 and 9 by hand afterwards (Table 3)."""
    result = by_joint(calibrate(read_measured_csv(io.StringIO(table2_csv()))))
    ok = {name for name, c in result.items() if c.identifiable}
    assert ok == {"servo2", "servo4", "servo10"}
    for servo in (1, 3, 5, 6, 7, 9, 11, 12):
        assert "below 0.05 N·m" in result[f"servo{servo}"].reason
    assert "encoder steps" in result["servo8"].reason
    assert "one frame" in result["servo4"].reason


def test_zero_torque_joint_is_not_identifiable():
    text = HEADER + "".join(f"{f},still,{1.0 + f},{0.5 + f},0\n" for f in range(4))
    (c,) = calibrate(read_measured_csv(io.StringIO(text)))
    assert not c.identifiable and math.isnan(c.k_deg_per_Nm)
    assert "every torque is zero" in c.reason
    assert c.to_json()["k_deg_per_Nm"] is None


def test_noisy_data_gives_honest_standard_error_and_relative_se_flag():
    rng = np.random.default_rng(7)
    tau = rng.uniform(-2.0, 2.0, size=200)
    k_true = 1.7
    q_meas = rng.uniform(-30.0, 30.0, size=200)
    noise = rng.normal(scale=0.05, size=200)
    lines = [HEADER] + [
        f"{i},knee,{q_meas[i] + k_true * tau[i] + noise[i]:.17g},{q_meas[i]:.17g},{tau[i]:.17g}\n"
        for i in range(200)
    ]
    (c,) = calibrate(read_measured_csv(io.StringIO("".join(lines))))
    expected_se = 0.05 / math.sqrt(float(tau @ tau))
    assert c.identifiable and c.reason == ""
    assert c.se_deg_per_Nm == pytest.approx(expected_se, rel=0.2)
    assert abs(c.k_deg_per_Nm - k_true) < 4.0 * c.se_deg_per_Nm
    # The same noise around a k of 0.005 °/(N·m) leaves it too uncertain.
    lines = [HEADER] + [
        f"{i},knee,{q_meas[i] + 0.005 * tau[i] + noise[i]:.17g},{q_meas[i]:.17g},{tau[i]:.17g}\n"
        for i in range(200)
    ]
    (c,) = calibrate(read_measured_csv(io.StringIO("".join(lines))), resolution_deg=0.0)
    assert not c.identifiable and "standard error" in c.reason


def test_servo_zero_offset_shows_in_the_intercept_fit():
    tau = np.array([0.5, 1.0, 1.5, 2.0])
    text = HEADER + "".join(
        f"{i},hip,{2.0 * t + 0.3:.17g},0.0,{t:.17g}\n" for i, t in enumerate(tau)
    )
    (c,) = calibrate(read_measured_csv(io.StringIO(text)))
    assert c.k_with_offset_deg_per_Nm == pytest.approx(2.0)
    assert c.offset_deg == pytest.approx(0.3)
    assert c.k_deg_per_Nm == pytest.approx(2.0 + 0.3 * tau.sum() / (tau @ tau))


@pytest.mark.parametrize(
    "text, message",
    [
        ("", "empty file"),
        ("frame,joint,q_cmd_deg,tau_Nm\n0,a,1,2\n", r"line 1: missing column\(s\) q_meas_deg"),
        (HEADER, "a header but no measurements"),
        (HEADER + "0,a,1,2,3\n1,a,x,2,3\n", "line 3: q_cmd_deg 'x' is not a number"),
        (HEADER + "0,a,1,nan,3\n", "line 2: q_meas_deg is 'nan'"),
        (HEADER + "0,a,1,2,inf\n", "line 2: tau_Nm is 'inf'"),
        (HEADER + "0.5,a,1,2,3\n", "line 2: frame '0.5' is not a whole number"),
        (HEADER + "0,a,1,2\n", "line 2: 4 value"),
        (HEADER + "0,,1,2,3\n", "line 2: empty joint name"),
        (HEADER + "0,a,1,2,3\n\n0,a,1,2,3\n", "line 4: frame 0 of a already given on line 2"),
    ],
)
def test_malformed_csv_is_refused_with_line_numbers(text, message):
    with pytest.raises(CalibrationError, match=message):
        read_measured_csv(io.StringIO(text))


def test_columns_in_any_order_and_files_on_disk(tmp_path):
    path = tmp_path / "m.csv"
    path.write_text("tau_Nm,note,joint,q_meas_deg,frame,q_cmd_deg\n2,x,knee,10,0,13\n")
    m = read_measured_csv(path)
    assert m.joint_names == ("knee",) and m.q_cmd_deg[0] == 13.0 and m.tau_Nm[0] == 2.0
    (c,) = calibrate(m)
    assert c.k_deg_per_Nm == 1.5
    with pytest.raises(CalibrationError, match="cannot read"):
        read_measured_csv(tmp_path / "missing.csv")
