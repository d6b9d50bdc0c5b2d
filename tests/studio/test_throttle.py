"""Throttle: a burst of values costs a call or two, and the last value is always shown."""

from __future__ import annotations

import threading

from app.studio.throttle import Throttle
from tests.studio.conftest import GUARD_S


def test_a_burst_is_shown_by_few_calls_ending_on_its_last_value():
    seen: list[int] = []
    last = threading.Event()

    def show(value: int) -> None:
        seen.append(value)
        if value == 999:
            last.set()

    throttle: Throttle[int] = Throttle(0.2, show, name="test-throttle")
    for value in range(1000):
        throttle.submit(value)
    assert last.wait(GUARD_S), "the burst's last value was never shown"
    assert seen[-1] == 999
    assert throttle.calls == len(seen) < 1000
    assert seen == sorted(seen)


def test_cancel_drops_the_kept_value():
    seen: list[int] = []
    shown = threading.Event()
    throttle = Throttle(60.0, lambda value: (seen.append(value), shown.set()), name="test")
    throttle.submit(1)
    assert shown.wait(GUARD_S)
    throttle.submit(2)  # kept for a minute
    throttle.cancel()
    assert seen == [1] and throttle._timer is None
