"""Battery and specific-resistance arithmetic against closed forms and definitions."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from app.core.simulation.battery import (
    BatteryError,
    battery_minutes,
    energy_figures,
    positive_work_J,
    run_energy_figures,
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
    walked = np.array([[0.0, 0.0], [3.0, 4.0]])  # 5 m, of which 3 m along the plan's x
    planned = np.array([[0.0, 0.0], [6.0, 0.0]])
    f = energy_figures(energy, vin, 6.0, 9.81, walked, planned, 120.0, pack_Wh=10.0)
    assert f.average_power_W == pytest.approx((3600 + 7200) / 3600)  # braking not banked
    assert f.average_current_A == pytest.approx(3600 / 12 / 3600 + 7200 / 24 / 3600)
    assert f.peak_current_A == 2.0 and f.peak_current_bound_A == pytest.approx(3.5)
    assert f.electrical_J == pytest.approx(10300.0)
    assert f.sr_electrical == pytest.approx(10300.0 / (6.0 * 9.81 * 3.0))
    assert f.sr_planned == pytest.approx(120.0 / (6.0 * 9.81 * 6.0))
    # 10 Wh at 3 W: 10/3 h = 200 min.
    assert f.battery_minutes == pytest.approx(200.0)


def test_the_currents_say_whose_they_are_when_the_packs_average_exceeds_one_servos_peak():
    """Three servos each drawing 1 A on average (peaks 1.5 A) at 12 V for an hour: the pack
    averages 3 A, more than any one servo's peak; the line and the JSON say which is whose."""
    energy = _energy([12.0 * 3600.0] * 3, 3600.0, peaks=(1.5, 1.5, 1.5))
    still = np.zeros((2, 2))
    f = energy_figures(energy, np.full(3, 12.0), 6.0, 9.81, still, still, 0.0)
    assert f.average_current_A == pytest.approx(3.0) and f.peak_current_A == 1.5
    line = f.labelled_currents()
    assert "pack average 3.00 A" in line and "peak 1.50 A on one servo" in line
    assert "pack peak ≤ 4.50 A" in line
    data = f.to_json()
    assert data["average_current_A"] == data["pack_average_current_A"] == f.average_current_A
    assert data["peak_current_A"] == data["one_servo_peak_current_A"] == 1.5


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


def _run_of(planned_x_m: float):
    """A 1-joint robot of 6 kg, a plan of 5 samples 0.5 s apart moving the base `planned_x_m`
    along x with the joint at 2 rad/s, and a run that covered 3 m before falling at 1 s."""
    robot = SimpleNamespace(
        joints=[SimpleNamespace(idx_v=6)],
        mass_kg=6.0,
        model=SimpleNamespace(gravity=SimpleNamespace(linear=np.array([0.0, 0.0, -9.81]))),
    )
    t = np.arange(5) * 0.5
    q = np.zeros((5, 8))
    q[:, 0] = np.linspace(0.0, planned_x_m, 5)
    v = np.zeros((5, 7))
    v[:, 6] = 2.0
    plan = SimpleNamespace(q=q, v=v, dt=0.5)
    ran = np.zeros((5, 8))
    ran[:, 0] = [0.0, 1.5, 3.0, 0.0, 0.0]  # after the fall (t > 1 s) the base is not counted
    result = SimpleNamespace(
        energy=_energy([30.0], 1.0, peaks=(1.0,)), t=t, simulated_until_s=1.0, q=ran
    )
    return robot, plan, result


def test_a_run_counts_its_simulated_stretch_and_asks_for_torques_only_when_it_travels():
    robot, plan, result = _run_of(6.0)
    tau = np.full((5, 1), 1.5)
    f = run_energy_figures(result, robot, plan, np.array([12.0]), lambda: tau, pack_Wh=None)
    assert f.distance_m == pytest.approx(3.0) and f.planned_distance_m == pytest.approx(6.0)
    assert f.sr_electrical == pytest.approx(30.0 / (6.0 * 9.81 * 3.0))
    work = 1.5 * 2.0 * 2.0  # 3 W for the plan's 2 s
    assert f.planned_work_J == pytest.approx(work)
    assert f.sr_planned == pytest.approx(work / (6.0 * 9.81 * 6.0))

    robot, plan, result = _run_of(0.05)  # in place: no SR, the torques never asked for
    f = run_energy_figures(result, robot, plan, np.array([12.0]), lambda: pytest.fail("asked"))
    assert f.sr_planned is None
