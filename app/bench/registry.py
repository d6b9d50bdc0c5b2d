"""The bench's registry: what every entry gets (`BenchContext`), the entries by name in the
order they run (`ENTRIES`, filled by `@bench_entry(name)` in each stage's module), and the
studio steps several entries share (a free port, a motion with its torques)."""

from __future__ import annotations

import dataclasses
import socket
import threading
from collections.abc import Callable
from pathlib import Path

from app.bench.report import Figure
from app.studio import Studio
from panels.quiet import set_value

ROBAN_CANDIDATES = (
    Path(__file__).resolve().parents[2] / "tests" / "third_party" / "roban_s14" / "urdf"
    / "robanS14.urdf",
)  # fmt: skip


@dataclasses.dataclass(frozen=True)
class BenchContext:
    """What every bench entry gets: the running studio and the run's settings."""

    studio: Studio
    robot: str
    """The second robot of the load, slider and drag entries (servo_biped is the first)."""
    roban: Path | None
    """Roban S14's URDF when it is found."""
    repeats: int

    def robots(self) -> dict[str, str]:
        """name -> source of the load, slider and drag entries' robots."""
        return {"servo_biped": "servo_biped", Path(self.robot).stem: self.robot}


BenchEntry = Callable[[BenchContext], tuple[dict, list[Figure]]]
ENTRIES: dict[str, BenchEntry] = {}
"""Every bench entry by name, in the order they run: add one with `@bench_entry(name)`."""
OPT_IN = ("sweep",)
"""Entries that run only when asked (`--sweep`, or `--only sweep`): they take minutes."""


def bench_entry(name: str) -> Callable[[BenchEntry], BenchEntry]:
    """Register a function returning (raw results, figures) as the bench entry `name`."""

    def register(function: BenchEntry) -> BenchEntry:
        ENTRIES[name] = function
        return function

    return register


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def compute_torques(studio: Studio) -> None:
    """Compute the torques of the current motion and wait for them."""
    done = threading.Event()
    disconnect = studio.servo_rooms.torques.done.connect(lambda _result: done.set())
    studio.servo_rooms.torques.compute_torques()
    done.wait()
    disconnect()


def motion_with_torques(studio: Studio, robot: str, motion: str) -> None:
    """Load `robot`, generate the built-in `motion` from the Motions panel, compute its torques."""
    studio.robots.load(robot)
    set_value(studio.motions.panel.motion, motion)
    set_value(studio.motions.panel.generate, True)
    compute_torques(studio)
