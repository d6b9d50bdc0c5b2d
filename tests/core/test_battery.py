"""Battery and specific-resistance arithmetic against closed forms and definitions."""

from __future__ import annotations

import math

import numpy as np
import pytest

from app.core.simulation.battery import (
    BatteryError,
    battery_minutes,
    energy_figures,
    positive_work_J,
    specific_resistance,
)
from app.core.simulation.part_law import PartEnergy


def _energy(electrical, duration, peaks=(2.0, 0.5, 1.0)):
    electrical = np.asarray(electrical, dtype=float)
    return PartEnergy(
        electrical_J=electrical,
        joule_J=0.25 * np.abs(electrical),
        mechanical_J=0.75 * electrical,
        peak_current_A=np.asarray(peaks),
        rms_current_A=np.ones(3),
        duration_s=duration,
    )


def test_figures_against_closed_forms():
    # One hour drawing 3600 J on a 12 V joint, 7200 J on a 24 V joint, one joint braking.
    energy = _energy([3600.0, 7200.0, -500.0], 3600.0)
    vin = np.array([12.0, 24.0, 12.0])
    walked = np.array([[0.0, 0.0], [3.0, 4.0]])  # 5 m
    planned = np.array([[0.0, 0.0], [6.0, 0.0]])
    f = energy_figures(energy, vin, 6.0, 9.81, walked, planned, 120.0, pack_Wh=10.0)
    assert f.average_power_W == pytest.approx((3600 + 7200) / 3600)  # braking not banked
    assert f.average_current_A == pytest.approx(3600 / 12 / 3600 + 7200 / 24 / 3600)
    assert f.peak_current_A == 2.0 and f.peak_current_bound_A == pytest.approx(3.5)
    assert f.electrical_J == pytest.approx(10300.0)
    assert f.sr_electrical == pytest.approx(10300.0 / (6.0 * 9.81 * 5.0))
    assert f.sr_planned == pytest.approx(120.0 / (6.0 * 9.81 * 6.0))
    # 10 Wh at 3 W: 10/3 h = 200 min.
    assert f.battery_minutes == pytest.approx(200.0)


def test_a_motion_in_place_has_no_specific_resistance():
    assert specific_resistance(10.0, 5.0, 0.02) is None
    assert specific_resistance(10.0, 5.0, 2.0, 9.81) == pytest.approx(10.0 / (5 * 9.81 * 2))


def test_positive_work_is_the_integral_of_the_positive_power():
    t = np.linspace(0.0, 2.0, 2001)
    dq = np.stack([np.cos(np.pi * t), np.ones_like(t)], axis=1)
    tau = np.stack([np.full_like(t, 3.0), np.full_like(t, -1.0)], axis=1)
    # ∫₀² max(3 cos πt, 0) dt = 3·(1/π)·[sin]: positive on [0, ½] and [3/2, 2]: 2·3/π.
    assert positive_work_J(tau, dq, t[1] - t[0]) == pytest.approx(6.0 / math.pi, rel=1e-5)


@pytest.mark.parametrize("pack", [float("nan"), -1.0, 0.0, float("inf")])
def test_a_bad_pack_is_one_clear_error(pack):
    with pytest.raises(BatteryError, match="Wh"):
        battery_minutes(pack, 3.0)
