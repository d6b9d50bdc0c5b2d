"""app.core.parent_watch: a worker ends with its parent even while it holds the GIL in one long
C call (where a watching thread, like Dask's own, cannot run), and a worker asked for by a
short-lived thread outlives that thread (the kernel ties the parent-death signal to the
thread that started the child: the spawner thread is the one that starts them)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import psutil

from tests.serve_processes import ROOT, alive, poll

GUARD_S = 120.0

PARENT = textwrap.dedent(
    """
    import multiprocessing, sys, threading
    from app.core.parent_watch import die_with_parent, on_spawner_thread

    def busy(watching):
        die_with_parent()
        watching.set()
        print("child holds the GIL", file=sys.stderr, flush=True)
        sum(range(10**15))  # one C call: no other thread of this process runs meanwhile

    if __name__ == "__main__":
        ctx = multiprocessing.get_context("spawn")
        started = []
        watching = ctx.Event()
        def ask():  # a short-lived thread asks for the worker, then ends once it watches
            process = ctx.Process(target=busy, args=(watching,), daemon=False)
            on_spawner_thread(process.start)
            watching.wait()
            started.append((process.pid, threading.get_native_id()))
        thread = threading.Thread(target=ask)
        thread.start()
        thread.join()
        print(*started[0], flush=True)
        sys.stdin.read()  # until killed
    """
)


def test_a_busy_worker_outlives_the_asking_thread_and_dies_with_its_parent(tmp_path):
    script = tmp_path / "parent.py"
    script.write_text(PARENT)
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    parent = subprocess.Popen(
        [sys.executable, str(script)],
        cwd=ROOT,
        env=env,
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    child = None
    try:
        assert parent.stdout is not None and parent.stderr is not None
        # The parent's line on stdout, the child's on stderr: on one pipe the two could
        # interleave within a line (seen once on two pytest workers).
        pid, asking = (int(x) for x in parent.stdout.readline().split())
        child = psutil.Process(pid)
        # The asking thread is gone from the kernel too: had the child been started by it,
        # its parent-death signal would have come now.
        task = Path(f"/proc/{parent.pid}/task/{asking}")
        poll("the asking thread ended", lambda: not task.exists(), GUARD_S)
        assert alive(child)
        line = "-"
        while line and "GIL" not in line:  # the child is inside its C call
            line = parent.stderr.readline()
        assert "GIL" in line, "the child never said it holds the GIL"
        parent.send_signal(signal.SIGKILL)
        parent.wait(30)
        poll("the worker outlived its parent by 10 s", lambda: not alive(child), 10.0)
    finally:
        if parent.poll() is None:
            parent.kill()
            parent.wait()
        if child is not None and alive(child):
            child.kill()
