"""A worker thread's failure reaches the user in one line and still ends the job
(app.studio.notifier.failure_told): the torque feed-forward made to fail, once as a StudioError
(its message as it is, nothing logged) and once as a bug (its type and message, the traceback in
the log only). Either way `done` is announced with no result and no torques are kept."""

from __future__ import annotations

import logging

import pytest

from app.core.errors import StudioError
from app.studio import torques_session
from tests.studio.conftest import compute_torques


@pytest.fixture
def studio(studio):
    """The conftest's studio with the one-leg stand generated (no torques yet)."""
    studio.motions.panel.motion.value = "one_leg_stand"
    studio.motions.panel.generate.value = True
    assert studio.state.trajectory is not None and studio.state.work.torques is None
    return studio


def torques_failing_with(studio, monkeypatch, caplog, error: Exception):
    """Compute the torques with the feed-forward raising `error`: the Torques status line and
    what the session logged. The job ends with no result and no torques kept."""

    def fail(*_args, **_kwargs):
        raise error

    monkeypatch.setattr(torques_session, "torque_feedforward", fail)
    with caplog.at_level(logging.ERROR, logger="app.studio.torques_session"):
        assert compute_torques(studio) is None
    assert studio.state.work.torques is None
    logged = [r for r in caplog.records if r.name == "app.studio.torques_session"]
    return studio.servo_rooms.torques.panel.status.content, logged


def test_a_studio_error_is_told_as_it_is_and_not_logged(studio, monkeypatch, caplog) -> None:
    error = StudioError("no torques for this robot today")
    status, logged = torques_failing_with(studio, monkeypatch, caplog, error)
    assert status == "⚠️ no torques for this robot today"
    assert logged == []


@pytest.mark.expected_traceback("app.studio.torques_session")
def test_a_bug_is_told_in_one_line_and_its_traceback_logged(studio, monkeypatch, caplog) -> None:
    error = ZeroDivisionError("a bug on purpose")
    status, logged = torques_failing_with(studio, monkeypatch, caplog, error)
    assert status == "⚠️ ZeroDivisionError: a bug on purpose"
    (record,) = logged
    assert record.exc_info is not None and record.exc_info[0] is ZeroDivisionError
    assert record.getMessage() == "Torque feed-forward failed"
