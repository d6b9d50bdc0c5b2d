"""Shared test helpers: paths of the third-party robots (and a loader by name), a tiny biped URDF to mutate, and the
rule that a traceback in the studio's log fails the test that caused it."""

from __future__ import annotations

import logging
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
THIRD_PARTY_ROBOTS = REPO / "tests" / "third_party"
ROBAN_URDF = THIRD_PARTY_ROBOTS / "roban_s14" / "urdf" / "robanS14.urdf"
SIGMABAN_URDF = THIRD_PARTY_ROBOTS / "sigmaban" / "robot.urdf"
THIRD_PARTY_URDFS = {"roban": ROBAN_URDF, "sigmaban": SIGMABAN_URDF}


def load_robots(*names: str) -> dict:
    """{name: RobotModel} of the named robots: the built-ins by their name, "roban" (Roban
    S14) and "sigmaban" from tests/third_party."""
    from app.core.robot.loading import load_robot

    return {name: load_robot(THIRD_PARTY_URDFS.get(name, name)) for name in names}


def _link(name: str, mass: float = 0.5, geometry: str = "") -> str:
    inertial = (
        f'<inertial><mass value="{mass}"/><inertia ixx="0.001" iyy="0.001" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial>'
        if mass is not None
        else ""
    )
    visual = f"<visual><geometry>{geometry}</geometry></visual>" if geometry else ""
    return f'<link name="{name}">{inertial}{visual}</link>'


def _joint(
    name: str, parent: str, child: str, xyz: str, kind: str = "revolute", axis: str = "0 1 0"
) -> str:
    limit = '<limit lower="-1.5" upper="1.5" effort="5" velocity="6"/>' if kind != "fixed" else ""
    return (
        f'<joint name="{name}" type="{kind}"><origin xyz="{xyz}"/><parent link="{parent}"/>'
        f'<child link="{child}"/><axis xyz="{axis}"/>{limit}</joint>'
    )


def tiny_biped_urdf(
    extra: str = "", foot_geometry: str = '<box size="0.10 0.05 0.01"/>', pelvis_mass: float = 2.0
) -> str:
    """A 4-DOF biped: pelvis, per side a hip pitch and a knee, a foot box 5 mm below the ankle."""
    parts = [_link("pelvis", pelvis_mass, '<box size="0.1 0.2 0.1"/>')]
    for side, y in (("left", 0.05), ("right", -0.05)):
        parts += [
            _link(f"{side}_thigh", 0.4, '<cylinder radius="0.02" length="0.2"/>'),
            _link(f"{side}_shin", 0.3),
            _link(f"{side}_foot", 0.1, foot_geometry),
            _joint(f"{side}_hip_pitch", "pelvis", f"{side}_thigh", f"0 {y} -0.05"),
            _joint(f"{side}_knee", f"{side}_thigh", f"{side}_shin", "0 0 -0.2"),
            _joint(f"{side}_ankle", f"{side}_shin", f"{side}_foot", "0 0 -0.2", kind="fixed"),
        ]
    return '<?xml version="1.0"?>\n<robot name="tiny">' + "".join(parts) + extra + "</robot>\n"


@pytest.fixture
def write_urdf(tmp_path: Path):
    """Write URDF text to a file in the test's own folder and return its path."""

    def write(text: str, name: str = "robot.urdf") -> Path:
        path = tmp_path / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
        return path

    return write


class _Tracebacks(logging.Handler):
    """Every log record that carries a traceback (log.exception, exc_info=True)."""

    def __init__(self) -> None:
        super().__init__(level=logging.DEBUG)
        self.records: list[logging.LogRecord] = []

    def emit(self, record: logging.LogRecord) -> None:
        if record.exc_info is not None and record.exc_info[0] is not None:
            self.records.append(record)


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line(
        "markers",
        "expected_traceback(logger, ...): the test provokes a failure that these loggers log "
        "with its traceback by design (a third-party parser refusing a hostile file)",
    )


THIRD_PARTY_CHATTER = ("distributed",)
"""Loggers whose tracebacks are not the studio's: Dask logs every comm its cluster closes
(a worker ending, a sweep cancelled) with a traceback; a sweep's real failures reach the
studio's own log and the user through the sweep engine."""


@pytest.fixture(autouse=True)
def own_data_folder(tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch):
    """Each test's studio keeps its token, uploads, projects and autosaves in a folder of its
    own (`$BIPED_STUDIO_DATA`, inherited by the CLI processes a test starts): no test reads
    another's autosave or writes into the user's ~/.local/share, and tests can run side by
    side. A test that sets the variable or passes `data_dir` itself still wins."""
    monkeypatch.setenv("BIPED_STUDIO_DATA", str(tmp_path_factory.mktemp("data")))


@pytest.fixture(autouse=True)
def no_traceback_in_the_log(request: pytest.FixtureRequest) -> Iterator[None]:
    """Fail a test during which the studio logged a traceback (a callback that raised, a
    signal subscriber that failed, a thread that died), unless the test expects it from a
    named logger. The studio's log is where an error hidden from the user shows."""
    handler = _Tracebacks()
    root = logging.getLogger()
    root.addHandler(handler)
    died: list[str] = []
    previous_hook = threading.excepthook

    def thread_died(args: threading.ExceptHookArgs) -> None:
        name = args.thread.name if args.thread is not None else "?"
        died.append(f"thread {name}: {args.exc_type.__name__}: {args.exc_value}")
        previous_hook(args)

    threading.excepthook = thread_died
    try:
        yield
    finally:
        threading.excepthook = previous_hook
        root.removeHandler(handler)
    allowed = {
        name for mark in request.node.iter_markers("expected_traceback") for name in mark.args
    } | set(THIRD_PARTY_CHATTER)
    unexpected = [
        f"{record.name}: {record.getMessage()} ({record.exc_info[0].__name__}: "
        f"{record.exc_info[1]})"
        for record in handler.records
        if record.exc_info is not None
        and record.exc_info[0] is not None
        and not any(record.name == a or record.name.startswith(a + ".") for a in allowed)
    ]
    if unexpected or died:
        pytest.fail(
            "traceback(s) in the studio's log during this test:\n  "
            + "\n  ".join([*unexpected, *died]),
            pytrace=False,
        )
