"""A poisoned sweep point for tests/test_sweep_engine.py, top level so that a Dask worker unpickles
it (the workers are spawned with the test process's sys.path)."""

from __future__ import annotations

import dataclasses
import os

from app.core.collocation.settings import GaitSettings
from app.core.sweeps.sampling import SweepPoint

POISON_EXIT_CODE = 7


@dataclasses.dataclass(frozen=True)
class PoisonedSettings(GaitSettings):
    """Gait settings whose check ends the process that runs it, as a segfaulting solver or the
    kernel's OOM killer would: every worker that evaluates the point dies."""

    def validate(self) -> GaitSettings:
        os._exit(POISON_EXIT_CODE)


def poisoned(point: SweepPoint) -> SweepPoint:
    """`point` with settings that kill whichever process evaluates it."""
    fields = {f.name: getattr(point.settings, f.name) for f in dataclasses.fields(GaitSettings)}
    return dataclasses.replace(point, settings=PoisonedSettings(**fields))
