"""Ctrl+C while `serve` starts is one line (issue 24, item 9: ~50 lines of tracebacks — a
half-imported trimesh's TypeError, Dask's "Nanny failed to start" — and once a studio that
went on starting). The terminal's Ctrl+C reaches the whole process group, workers included;
the test sends SIGINT to the group the same way, at two moments found by watching the process
(no fixed sleeps): while it imports its libraries, and once its worker processes start."""

from __future__ import annotations

import os
import signal
import subprocess

import psutil
import pytest

from tests.serve_processes import alive, poll, spawned_workers, start_serve

GUARD_S = 300.0


def _importing(process: psutil.Process) -> bool:
    """The interpreter has started loading the studio's libraries (numpy is mapped)."""
    try:
        return any("numpy" in m.path for m in process.memory_maps())
    except (psutil.NoSuchProcess, psutil.AccessDenied):
        return False


@pytest.mark.parametrize(
    "moment",
    [
        "importing",
        pytest.param(
            "workers starting",
            marks=pytest.mark.xfail(
                reason="a worker spawned while Ctrl+C reaches the process group can be "
                "interrupted inside Python's own start-up (before it can ignore SIGINT) and print "
                "'Fatal Python error: init_import_site'; multiprocessing's spawn resets the "
                "signal mask the spawner thread blocks (checked), so the fix needs the workers "
                "in their own process group; seen once in CI, open in issue 24's note",
                strict=False,
            ),
        ),
    ],
)
def test_ctrl_c_while_serve_starts_says_one_line(tmp_path, moment):
    serve = start_serve(
        tmp_path / "data",
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # its own process group, as a terminal's foreground job
    )
    process = psutil.Process(serve.pid)
    workers: list[psutil.Process] = []
    try:
        if moment == "importing":
            poll("the studio began importing", lambda: _importing(process), GUARD_S)
        else:

            def started() -> bool:
                workers[:] = spawned_workers(process)
                return bool(workers)

            poll("the studio started a worker process", started, GUARD_S)
        os.killpg(serve.pid, signal.SIGINT)  # what Ctrl+C in its terminal does
        _, stderr = serve.communicate(timeout=GUARD_S)
    finally:
        if serve.poll() is None:
            os.killpg(serve.pid, signal.SIGKILL)
            serve.wait()
    banner = "╭│╰"  # viser's box with the address, printed by a studio that started serving
    lines = [line for line in stderr.splitlines() if line.strip() and line[0] not in banner]
    assert serve.returncode in (130, -signal.SIGINT), (serve.returncode, stderr)
    assert len(lines) <= 1 and "Traceback" not in stderr, stderr
    assert all("stopped (Ctrl+C)" in line for line in lines), stderr
    poll("a worker outlived the stopped studio", lambda: not any(alive(w) for w in workers), 10)
