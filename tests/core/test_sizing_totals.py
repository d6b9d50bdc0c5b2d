"""What a sizing's servos add up to: count, mass and price summed over the choices a brute
force over the catalogue makes, the price only where every chosen servo publishes one in one
currency, and a price changed in a copy of the catalogue changes the choice and the total."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from app.core.servo.catalogue import record_from_mapping
from app.core.servo.sizing import check_joint, size_joints
from app.core.servo.sizing_totals import totals


def servo(key: str, stall: float, mass: float, price: float | None, currency: str = "USD"):
    data = {
        "key": key, "maker": "Acme", "model": key.upper(), "supply_voltage_V": 12.0,
        "stall_torque_Nm": stall, "no_load_speed_rpm": 60, "mass_kg": mass, "gear_ratio": 200,
        "sources": {f: "bench" for f in ("supply_voltage_V", "stall_torque_Nm",
                                         "no_load_speed_rpm", "mass_kg", "gear_ratio")},
    }  # fmt: skip
    if price is not None:
        data |= {"price": price, "price_currency": currency}
        data["sources"]["price"] = "shop"
    return record_from_mapping(data, "test")


CATALOGUE = {
    r.key: r
    for r in (
        servo("small", 1.0, 0.05, 20.0),
        servo("mid", 3.0, 0.09, 45.0),
        servo("big", 8.0, 0.16, 90.0),
        servo("huge", 20.0, 0.30, 400.0),
    )
}
JOINTS = ("hip", "knee", "ankle")


@pytest.fixture(scope="module")
def work():
    rng = np.random.default_rng(5)
    peaks = np.array([0.4, 2.0, 5.5])  # each joint needs a bigger servo than the last
    tau = rng.uniform(-1.0, 1.0, (200, 3)) * peaks
    w = rng.uniform(-0.5, 0.5, (200, 3))
    return w, tau


def brute_force(w, tau, catalogue, margin, by):
    """Per joint, the cheapest (lightest) record that holds, by trying every one."""
    out = []
    for j in range(len(JOINTS)):
        holding = [
            r for r in catalogue.values()
            if check_joint(r, w[:, j], tau[:, j], 1.0, margin).holds
        ]  # fmt: skip
        cost = (lambda r: r.price) if by == "price" else (lambda r: r.mass_kg)
        out.append(min(holding, key=lambda r: (cost(r), r.key)) if holding else None)
    return out


@pytest.mark.parametrize("by", ["mass", "price"])
def test_totals_are_the_sums_over_the_brute_force_choice(work, by):
    w, tau = work
    sizing = size_joints(JOINTS, w, tau, 1.0, CATALOGUE, 0.3, by)
    chosen = brute_force(w, tau, CATALOGUE, 0.3, by)
    assert [j.choice for j in sizing.joints] == [r.key for r in chosen]
    total = totals(sizing, CATALOGUE)
    assert total.servos == 3
    assert total.mass_kg == pytest.approx(sum(r.mass_kg for r in chosen))
    assert (total.price, total.currency) == (sum(r.price for r in chosen), "USD")
    assert f"{total.price:.2f} USD" in total.line()


def test_a_price_changed_in_a_copy_changes_the_choice_and_the_total(work):
    w, tau = work
    before = totals(size_joints(JOINTS, w, tau, 1.0, CATALOGUE, 0.3, "price"), CATALOGUE)
    cheap = dict(CATALOGUE, big=dataclasses.replace(CATALOGUE["big"], price=30.0))
    sizing = size_joints(JOINTS, w, tau, 1.0, cheap, 0.3, "price")
    chosen = brute_force(w, tau, cheap, 0.3, "price")
    assert [j.choice for j in sizing.joints] == [r.key for r in chosen]
    after = totals(sizing, cheap)
    assert after.price == pytest.approx(sum(r.price for r in chosen))
    assert after.price < before.price


def test_no_price_where_one_is_unpublished_or_in_another_currency(work):
    w, tau = work
    unpriced = dict(CATALOGUE, mid=dataclasses.replace(CATALOGUE["mid"], price=None))
    total = totals(size_joints(JOINTS, w, tau, 1.0, unpriced, 0.3, "mass"), unpriced)
    assert total.price is None and total.unpriced == ("mid",)
    assert "price unpublished for mid" in total.line()
    euros = dict(CATALOGUE, mid=dataclasses.replace(CATALOGUE["mid"], price_currency="EUR"))
    total = totals(size_joints(JOINTS, w, tau, 1.0, euros, 0.3, "mass"), euros)
    assert total.price is None and "different currencies" in total.line()
    assert math.isfinite(total.mass_kg)
