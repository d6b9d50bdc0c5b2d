"""Hostile project files: each is refused with a message naming what is wrong (the field, the
entry, the version), before anything is installed. The studio side (the work untouched) is
in tests/studio/test_projects_in_studio.py."""

from __future__ import annotations

import io
import json
import os
import subprocess
import sys
import textwrap
import zipfile
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from app.core.projects.codec import ProjectError
from app.core.projects.files import parse_project, project_bytes, read_project
from app.core.projects.project import Project, check_fits
from app.core.projects.robot_files import load_project_robot, robot_source
from app.core.robot.loading import load_robot

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def servo_biped():
    return load_robot("servo_biped")


@pytest.fixture(scope="module")
def good(servo_biped) -> bytes:
    from app.core.motions.library import run_motion

    motion = run_motion(servo_biped, "com_shift").trajectory
    return project_bytes(
        Project(robot=robot_source(servo_biped), q=motion.q[3], motion=motion, time_s=0.5)
    )


def rewrite(
    data: bytes,
    manifest: Callable[[dict], object] | None = None,
    entries: dict[str, bytes] | None = None,
    text: Callable[[str], str] | None = None,
) -> bytes:
    """A copy of a project archive with its manifest edited and entries replaced or added."""
    source = zipfile.ZipFile(io.BytesIO(data))
    out = io.BytesIO()
    with zipfile.ZipFile(out, "w") as target:
        for info in source.infolist():
            content = source.read(info)
            if info.filename == "manifest.json":
                if manifest is not None:
                    parsed = json.loads(content)
                    manifest(parsed)
                    content = json.dumps(parsed).encode()
                if text is not None:
                    content = text(content.decode()).encode()
            if entries is None or info.filename not in entries:
                target.writestr(info.filename, content)
        for name, content in (entries or {}).items():
            target.writestr(name, content)
    return out.getvalue()


def npy(array: np.ndarray) -> bytes:
    buffer = io.BytesIO()
    np.save(buffer, array, allow_pickle=True)
    return buffer.getvalue()


def npy_header(shape: tuple[int, ...]) -> bytes:
    """An .npy header declaring `shape` of float64, with no data after it."""
    buffer = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        buffer, {"descr": "<f8", "fortran_order": False, "shape": shape}
    )
    return buffer.getvalue()


def _set(path: list, value: object) -> Callable[[dict], None]:
    def edit(manifest: dict) -> None:
        node = manifest
        for key in path[:-1]:
            node = node[key]
        node[path[-1]] = value

    return edit


CASES = {
    "newer version": (
        lambda g: rewrite(g, _set(["version"], 99)),
        "saved by a newer Biped Studio .*version 99",
    ),
    "not our format": (
        lambda g: rewrite(g, _set(["format"], "other")),
        "not a Biped Studio project",
    ),
    "truncated zip": (lambda g: g[: len(g) // 2], "not a valid zip"),
    "corrupt entry": (
        lambda g: g.replace(b"\x93NUMPY", b"\x93NUMPZ", 1),
        r"not a readable array|damaged",
    ),
    "zip slip": (
        lambda g: rewrite(g, entries={"../../evil.npy": b"x"}),
        "'../../evil.npy' is not one",
    ),
    "absolute entry": (
        lambda g: rewrite(g, entries={"/etc/evil": b"x"}),
        "is not one a project holds",
    ),
    "NaN scalar": (
        lambda g: rewrite(g, text=lambda t: t.replace('"time_s":0.5', '"time_s":NaN')),
        r"project.time_s is nan; give a finite number",
    ),
    "infinite scalar": (
        lambda g: rewrite(g, text=lambda t: t.replace('"time_s":0.5', '"time_s":-Infinity')),
        r"project.time_s is -inf",
    ),
    "NaN in an array": (
        lambda g: rewrite(
            g, entries={"arrays/project.motion.q.npy": npy(np.full((201, 19), np.nan))}
        ),
        r"project.motion.q contains NaN",
    ),
    "objects in an array": (
        lambda g: rewrite(
            g, entries={"arrays/project.q.npy": npy(np.array([object()] * 3, dtype=object))}
        ),
        r"project.q: not a readable array",
    ),
    "text instead of a number": (
        lambda g: rewrite(g, _set(["project", "time_s"], "soon")),
        r"project.time_s is 'soon'; give a number",
    ),
    "unknown stance": (
        lambda g: rewrite(g, _set(["project", "stance"], "sideways")),
        r"project.stance is 'sideways'; give one of",
    ),
    "missing pose": (
        lambda g: rewrite(g, lambda m: m["project"].pop("q")),
        r"project.q is missing",
    ),
    "keyframes not a list": (
        lambda g: rewrite(g, _set(["project", "keyframes"], {"a": 1})),
        r"project.keyframes is .*; give a list",
    ),
    "reference to a missing entry": (
        lambda g: rewrite(g, _set(["project", "q"], {"array": "arrays/nowhere.npy"})),
        r"refers to 'arrays/nowhere.npy', which is not in the file",
    ),
    "too many entries": (
        lambda g: rewrite(g, entries={f"arrays/x{i}.npy": b"" for i in range(2001)}),
        r"entries, over the limit",
    ),
    "huge manifest (zip bomb)": (
        lambda g: rewrite(g, text=lambda t: t[:-1] + ',"pad":"' + " " * (17 * 2**20) + '"}'),
        r"'manifest.json' is too large",
    ),
    "deeply nested manifest": (
        lambda g: rewrite(
            g, text=lambda t: t[:-1] + ',"pad":' + "[" * 100_000 + "]" * 100_000 + "}"
        ),
        r"nested too deeply|not valid JSON",
    ),
    "huge declared shape (allocated before it is read)": (
        lambda g: rewrite(g, entries={"arrays/project.q.npy": npy_header((10**9, 10**6)) + b"x"}),
        r"project.q: its header declares shape \(1000000000, 1000000\) .* but the entry holds",
    ),
    "fewer bytes than the header says": (
        lambda g: rewrite(g, entries={"arrays/project.q.npy": npy(np.zeros(19))[:-8]}),
        r"project.q: its header declares shape \(19,\) of float64 \(152 bytes\)",
    ),
    "motion of the wrong length": (
        lambda g: rewrite(g, entries={"arrays/project.motion.t.npy": npy(np.arange(5) * 0.01)}),
        r"project.motion: trajectory",
    ),
}


@pytest.mark.parametrize("case", list(CASES))
def test_hostile_project_is_refused_naming_the_problem(good, case):
    make, message = CASES[case]
    with pytest.raises(ProjectError, match=message):
        parse_project(make(good), "crafted.bstudio")


def test_a_project_whose_robot_is_gone_is_refused(good, tmp_path):
    project = parse_project(rewrite(good, _set(["project", "robot", "builtin"], "robot_2049")), "x")
    with pytest.raises(ProjectError, match="'robot_2049' is not a built-in robot"):
        load_project_robot(project.robot, tmp_path)


def test_an_embedded_robot_with_a_zip_slip_is_refused(good, tmp_path):
    evil = io.BytesIO()
    with zipfile.ZipFile(evil, "w") as z:
        z.writestr("robot/robot.urdf", "<robot name='x'/>")
        z.writestr("../outside.txt", "x")
    crafted = rewrite(
        good,
        lambda m: m["project"]["robot"].update(
            builtin="",
            urdf_entry="robot/robot.urdf",
            files={"bytes": "blobs/project.robot.files.bin"},
        ),
        entries={"blobs/project.robot.files.bin": evil.getvalue()},
    )
    project = parse_project(crafted, "x")
    with pytest.raises(ProjectError, match="points outside the archive"):
        load_project_robot(project.robot, tmp_path / "uploads")
    assert not (tmp_path / "outside.txt").exists()


def test_a_pose_of_the_wrong_size_does_not_fit(good, servo_biped):
    project = parse_project(rewrite(good, entries={"arrays/project.q.npy": npy(np.zeros(7))}), "x")
    with pytest.raises(ProjectError, match="the pose has 7 values"):
        check_fits(project, servo_biped)


def test_a_fifo_is_refused_without_blocking(tmp_path):
    fifo = tmp_path / "pipe.bstudio"
    os.mkfifo(fifo)
    with pytest.raises(ProjectError, match="a pipe"):
        read_project(fifo)


def test_a_full_disk_keeps_the_earlier_autosaves(tmp_path):
    """A real write failure (the file-size limit, EFBIG, as a full disk gives ENOSPC): the
    autosave is refused, the earlier ones stay whole and no temporary file is left."""
    script = textwrap.dedent(
        f"""
        import resource, signal
        from pathlib import Path
        from app.core.projects.autosave import AutosaveStore
        from app.core.projects.codec import ProjectError
        store = AutosaveStore(Path({str(tmp_path / "autosave")!r}))
        first = [store.write(bytes([i]) * 1000) for i in range(3)]
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (4096, 4096))
        try:
            store.write(b"x" * 100_000)
        except ProjectError as error:
            print("refused:", error)
        """
    )
    done = subprocess.run(
        [sys.executable, "-c", script], cwd=ROOT, capture_output=True, text=True, check=True
    )
    assert "refused:" in done.stdout and "nothing was written" in done.stdout
    files = sorted((tmp_path / "autosave").iterdir())
    assert [f.read_bytes() for f in files] == [bytes([i]) * 1000 for i in range(3)]
