"""What the tests that run a real `serve` (or a parent of workers) and watch its processes
share: a bounded poll (no fixed sleeps), whether a process still lives, its spawned workers, and
starting `serve` on a free port with its own data folder."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import psutil

from tests.studio.conftest import free_port

ROOT = Path(__file__).resolve().parents[1]


def poll(what: str, condition, seconds: float, every_s: float = 0.05) -> None:
    """Wait until `condition()` holds; fail with `what` after `seconds`."""
    deadline = time.monotonic() + seconds
    while not condition():
        assert time.monotonic() < deadline, what
        time.sleep(every_s)


def alive(process: psutil.Process) -> bool:
    try:
        return process.is_running() and process.status() != psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        return False


def spawned_workers(process: psutil.Process) -> list[psutil.Process]:
    """`process`'s worker processes (spawned interpreters: Dask workers, solver workers)."""
    try:
        children = process.children(recursive=True)
    except psutil.NoSuchProcess:
        return []
    found = []
    for child in children:
        try:
            if "multiprocessing.spawn" in " ".join(child.cmdline()):
                found.append(child)
        except psutil.NoSuchProcess:
            continue
    return found


def start_serve(data: Path, *options: str, **popen: Any) -> subprocess.Popen:
    """`python -m app serve` on a free port with `data` as its data folder."""
    env = {**os.environ, "BIPED_STUDIO_DATA": str(data)}
    command = [sys.executable, "-m", "app", "serve", "--port", str(free_port()), *options]
    return subprocess.Popen(command, cwd=ROOT, env=env, **popen)
