"""The built-in catalogue's published prices: each with its source (URL, date, currency), and
sizing by price over the built-in catalogue against a brute-force search written from the
files themselves (TOML and BAM's m1 fits read here, not through the code under test)."""

from __future__ import annotations

import json
import math
import re
import tomllib

import numpy as np
import pytest

from app.core.servo.catalogue import BAM_PARAMS_DIR, SERVOS_DIR, load_catalogue
from app.core.servo.sizing import size_joints
from app.core.servo.sizing_totals import totals
from tests.core.test_servo_sizing import _brute_force

PRICED = {"mx106", "xc430_w240", "xh430_w350", "xl330_m288", "xm540_w270", "xw540_t260"}
"""The built-in servos whose list price was found (README.md in robots/servos)."""


def _files() -> dict[str, dict]:
    return {p.stem: tomllib.loads(p.read_text()) for p in sorted(SERVOS_DIR.glob("*.toml"))}


def _servo(data: dict) -> dict:
    """A record's envelope from its file: BAM's m1 (kt, R) with the [firmware] table where it
    names an identified model (τs = kt·vin·max_pwm/R, ω0 = vin·max_pwm/kt, |τ| ≤ kt·I_lim),
    else the datasheet's stall torque and no-load speed; its price in place of the mass."""
    out = {"key": data["key"], "mass": data["price"]}  # _brute_force minimises "mass"
    if "identified" in data:
        m1 = json.loads((BAM_PARAMS_DIR / data["identified"] / "m1.json").read_text())
        fw = data["firmware"]
        out["stall"] = m1["kt"] * fw["vin_V"] * fw["max_pwm"] / m1["R"]
        out["w0"] = fw["vin_V"] * fw["max_pwm"] / m1["kt"]
        if "current_limit_A" in fw:
            out["limit"] = m1["kt"] * fw["current_limit_A"]
    else:
        out["stall"] = data["stall_torque_Nm"]
        out["w0"] = data["no_load_speed_rpm"] * 2 * math.pi / 60
    return out


def test_every_published_price_has_its_source_with_a_date_and_a_currency():
    files = _files()
    assert {k for k, data in files.items() if "price" in data} == PRICED
    for key in PRICED:
        data = files[key]
        assert data["price"] > 0 and data["price_currency"] == "USD", key
        source = data["sources"]["price"]
        assert source.startswith("https://"), key
        assert re.search(r"\b20\d\d-\d\d-\d\d\b|\b(March|May) 20\d\d\b", source), key
        assert "USD" in source and f"{data['price']:,.2f}" in source, key
    catalogue = load_catalogue()
    assert {k for k, r in catalogue.items() if r.price is not None} == PRICED


@pytest.mark.parametrize("seed", range(4))
def test_sizing_by_price_is_the_cheapest_choice_of_a_brute_force_search(seed):
    catalogue = load_catalogue()
    servos = [_servo(data) for data in _files().values() if "price" in data]
    rng = np.random.default_rng(seed)
    scales_tau = np.array([0.05, 0.3, 1.0, 2.5, 5.0, 40.0])  # the last: no servo holds it
    scales_w = np.array([6.0, 3.0, 2.0, 1.0, 0.5, 0.1])
    n = len(scales_tau)
    w = rng.uniform(-1, 1, (60, n)) * scales_w
    tau = rng.uniform(-1, 1, (60, n)) * scales_tau
    margin = float(rng.choice([0.0, 0.3]))
    sizing = size_joints([f"j{i}" for i in range(n)], w, tau, 1.0, catalogue, margin, by="price")
    expected = _brute_force(w, tau, servos, margin)
    assert [j.choice for j in sizing.joints] == expected
    assert expected[-1] is None
    assert len({c for c in expected if c is not None}) >= 3  # the search is not trivial
    assert any("without a price left out" in note for note in sizing.notes)
    chosen = [c for c in expected if c is not None]
    price = {s["key"]: s["mass"] for s in servos}
    total = totals(sizing, catalogue)
    assert total.currency == "USD" and total.unpriced == ()
    assert total.price == pytest.approx(math.fsum(price[c] for c in chosen), rel=1e-12)


def test_a_price_changed_in_a_catalogue_copy_changes_the_cheapest_choice(tmp_path):
    import shutil

    copy = tmp_path / "servos"
    shutil.copytree(SERVOS_DIR, copy, ignore=shutil.ignore_patterns("bam"))
    tau = np.array([[0.2], [-0.3], [0.35]])  # XL330 cannot; XC430 (137.89 USD) is cheapest
    w = np.zeros_like(tau)
    before = size_joints(["j"], w, tau, 1.0, load_catalogue(copy), 0.3, by="price")
    assert before.joints[0].choice == "xc430_w240"
    path = copy / "xc430_w240.toml"
    path.write_text(path.read_text().replace("price = 137.89", "price = 900.0"))
    after = size_joints(["j"], w, tau, 1.0, load_catalogue(copy), 0.3, by="price")
    assert after.joints[0].choice == "xh430_w350"  # 413.89 USD, the next cheapest that holds
