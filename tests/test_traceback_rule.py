"""The suite's rule, tested: a traceback in the studio's log, or a thread that dies, fails the
test during which it happened (tests/conftest.py), unless the test names the logger that
logs it by design. Run in a separate pytest so that the failures are its, not ours."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

INNER = """
import logging
import threading

import pytest


def test_logs_a_traceback():
    try:
        raise ValueError("hidden from the user")
    except ValueError:
        logging.getLogger("app.studio.somewhere").exception("a callback failed")


def test_a_thread_dies():
    def die():
        raise RuntimeError("a worker thread died")

    thread = threading.Thread(target=die, name="doomed")
    thread.start()
    thread.join()


def test_only_a_warning():
    logging.getLogger("app.studio.somewhere").warning("a refused file, said in one line")


@pytest.mark.expected_traceback("app.core.robot")
def test_an_expected_traceback():
    try:
        raise ValueError("a hostile mesh")
    except ValueError:
        logging.getLogger("app.core.robot.meshes").exception("the mesh library refused it")
"""


def test_the_rule_fails_exactly_the_tests_that_logged_a_traceback(tmp_path: Path) -> None:
    inner = tmp_path / "test_inner.py"
    inner.write_text(INNER)
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    run = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "tests.conftest", "-rE", str(inner)],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    out = run.stdout + run.stderr
    assert run.returncode != 0, out
    errors = set(re.findall(r"ERROR \S*::(\w+)", out))
    assert errors == {"test_logs_a_traceback", "test_a_thread_dies"}, out
    assert "hidden from the user" in out and "a worker thread died" in out
