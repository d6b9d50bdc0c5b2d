"""Worker processes end with the process that started them, however it ends: Ctrl+C, a crash,
an out-of-memory kill or `kill -9` of `serve` (issue 24: 3 sweep workers outlived a killed
studio by a minute or more).

Each worker calls `die_with_parent()` first thing. On Linux it asks the kernel for SIGKILL
when its parent ends (`prctl(PR_SET_PDEATHSIG)`): the kernel delivers it even while the
worker is deep in a solve that holds the GIL, where a watching thread could not run. The
signal is tied to the parent's *thread* that started the child, so the studio starts its
worker processes from threads that live as long as it does: `on_spawner_thread` runs the
start on one permanent thread, "process-spawner" (Dask's nannies start their workers from
each process's own long-lived watch thread), with Ctrl+C blocked from birth. Elsewhere (no prctl) a daemon thread polls the
parent's pid. A worker whose parent is already gone when it starts exits at once.

For Dask's worker processes this module is also a worker *preload* (`dask_setup`): the
local cluster names it, and passes the studio's pid in PARENT_ENV.
"""

from __future__ import annotations

import ctypes
import multiprocessing
import os
import queue
import signal
import sys
import threading
import time
from collections.abc import Callable
from typing import Any, TypeVar

PR_SET_PDEATHSIG = 1
"""prctl option: the signal this process gets when its parent (thread) ends."""
PARENT_ENV = "BIPED_STUDIO_PARENT_PID"
"""The environment variable naming the pid a worker must not outlive (Dask's workers)."""
POLL_S = 0.5
"""Where prctl is missing: how often the watching thread looks at the parent's pid [s]."""
T = TypeVar("T")


def die_with_parent(parent_pid: int | None = None) -> None:
    """End this process when `parent_pid` ends (default: the multiprocessing parent, else
    PARENT_ENV, else the current parent); exit now if it already has."""
    if parent_pid is None:
        parent = multiprocessing.parent_process()
        env = os.environ.get(PARENT_ENV, "")
        parent_pid = parent.pid if parent is not None else int(env) if env.isdigit() else None
    expected = parent_pid if parent_pid is not None else os.getppid()
    if not _kernel_watch():
        threading.Thread(target=_poll, args=(expected,), name="parent-watch", daemon=True).start()
    if os.getppid() != expected:  # it ended before the watch was set
        os._exit(1)


def _kernel_watch() -> bool:
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False


def _poll(expected: int) -> None:
    while os.getppid() == expected:
        time.sleep(POLL_S)
    os._exit(1)


def dask_setup(worker: Any) -> None:
    """Dask worker preload: the worker process ends with the studio (PARENT_ENV)."""
    die_with_parent()


_requests: queue.SimpleQueue[tuple[Callable[[], Any], queue.SimpleQueue]] = queue.SimpleQueue()
_spawner: threading.Thread | None = None
_spawner_lock = threading.Lock()


def on_spawner_thread(start: Callable[[], T]) -> T:
    """`start()` (which starts child processes) run on "process-spawner", a thread that lives
    as long as this process, so a child's parent-death signal comes only when the process
    ends, not when the thread that asked for the child ends. Returns what `start` returns;
    raises what it raises."""
    global _spawner
    if threading.current_thread() is _spawner:
        return start()
    with _spawner_lock:
        if _spawner is None:
            _spawner = threading.Thread(target=_serve, name="process-spawner", daemon=True)
            _spawner.start()
    answer: queue.SimpleQueue = queue.SimpleQueue()
    _requests.put((start, answer))
    ok, value = answer.get()
    if not ok:
        raise value
    return value


def _serve() -> None:
    # Ctrl+C is the main thread's to handle, never this one's. (Blocking it here does not
    # reach the children: multiprocessing's spawn resets the signal mask in the child, so a
    # worker hit by a terminal Ctrl+C inside Python's own start-up can still print; the
    # workers ignore SIGINT from their first line of Python on, and end with the studio.)
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    while True:
        start, answer = _requests.get()
        try:
            answer.put((True, start()))
        except BaseException as error:  # handed to the caller, raised there
            answer.put((False, error))
