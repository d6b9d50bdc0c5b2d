"""Child processes that use one BLAS/OpenMP thread each.

A worker process is one of several sharing the machine's cores (the feed-forward pool, the gait
solver next to the studio), so a linear-algebra library spinning up its own threads only
competes with its siblings: `plan` measured 109 % CPU for no gain, the extra being OpenBLAS's
threads waiting. The libraries read these variables once, when they load, so they are set
around the child's start and inherited; the parent's own environment is restored afterwards.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator

SINGLE_THREAD_ENV = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
"""Thread counts pinned to 1 in the workers."""


@contextlib.contextmanager
def single_thread_environment() -> Iterator[None]:
    """Processes started inside this block use one BLAS/OpenMP thread."""
    saved = {name: os.environ.get(name) for name in SINGLE_THREAD_ENV}
    os.environ.update(dict.fromkeys(SINGLE_THREAD_ENV, "1"))
    try:
        yield
    finally:
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value
