"""Typed edits of one joint's compensation or virtual-servo value (app.core.servo.edits)."""

from __future__ import annotations

import numpy as np
import pytest

from app.core.servo.compensation import MAX_ABS_K_DEG_PER_NM, CompensationParams
from app.core.servo.edits import (
    MAX_BACKLASH_DEG,
    EditRefused,
    SetBacklash,
    SetCompliance,
    SetEnabled,
    SetK,
    SetPhi,
)
from app.core.servo.model import ServoModel

NAMES = ("hip", "knee", "ankle")


def _inputs() -> tuple[CompensationParams, ServoModel]:
    params = CompensationParams(
        NAMES, np.array([1.0, 2.0, 3.0]), np.array([0.5, 0.0, 1.0]), np.array([True, False, True])
    )
    return params, ServoModel(NAMES, np.array([1.4, 1.5, 1.6]), np.array([0.2, 0.3, 0.4]))


@pytest.mark.parametrize(
    ("edit", "column"),
    [
        (SetK("knee", -7.5), "k"),
        (SetPhi("knee", 4.0), "phi"),
        (SetEnabled("knee", True), "enabled"),
        (SetCompliance("knee", 0.25), "compliance"),
        (SetBacklash("knee", 2.5), "backlash"),
    ],
)
def test_an_edit_changes_its_one_value_and_leaves_the_old_values_alone(edit, column):
    params, servo = _inputs()

    def columns(p: CompensationParams, s: ServoModel) -> dict[str, np.ndarray]:
        return {
            "k": p.k_deg_per_Nm,
            "phi": p.phi_deg,
            "enabled": p.enabled.astype(float),
            "compliance": s.compliance_deg_per_Nm,
            "backlash": s.backlash_deg,
        }

    before = {name: values.copy() for name, values in columns(params, servo).items()}
    new_params, new_servo = edit.apply(params, servo)
    after = columns(new_params, new_servo)
    for name, values in before.items():
        expected = values.copy()
        if name == column:
            expected[1] = float(edit.value)
        np.testing.assert_array_equal(after[name], expected, err_msg=name)
    for name, values in columns(params, servo).items():  # the inputs are never changed
        np.testing.assert_array_equal(values, before[name], err_msg=name)
    assert new_params.clearance_sign == params.clearance_sign


@pytest.mark.parametrize(
    "edit",
    [
        SetK("knee", MAX_ABS_K_DEG_PER_NM * 1.01),
        SetPhi("knee", -0.1),
        SetBacklash("knee", MAX_BACKLASH_DEG + 1.0),
        SetEnabled("knee", 2.0),
        SetCompliance("knee", float("nan")),
        SetK("knee", "1.0"),  # type: ignore[arg-type]  # what a crafted client could send
        SetK("elbow", 1.0),
    ],
)
def test_a_value_out_of_range_or_an_unknown_joint_is_refused_in_one_line(edit):
    params, servo = _inputs()
    with pytest.raises(EditRefused) as refused:
        edit.apply(params, servo)
    assert "\n" not in str(refused.value)
    assert edit.NAME in str(refused.value) or "elbow" in str(refused.value)
