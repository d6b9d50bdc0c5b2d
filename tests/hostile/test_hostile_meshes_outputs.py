"""Hostile meshes are reported, not inflated; outputs are written whole or not at all.

A robot with a bad mesh still loads (the mesh is listed with its reason, as a missing file
is), in bounded memory. An output whose write fails part-way leaves the previous file as it
was: the failure is made real with RLIMIT_FSIZE in the child (a file-size limit turns the
write into EFBIG once the file passes a few kilobytes)."""

from __future__ import annotations

import bz2
import json
import resource
import signal
import struct
from pathlib import Path

import pytest

from tests.conftest import tiny_biped_urdf
from tests.hostile.cli_runner import MAX_RSS_MB, assert_refused_in_one_line, run_cli


def _bz2_bomb(path: Path, megabytes: int) -> None:
    """`megabytes` MiB of zeros, bz2-compressed to a few hundred bytes."""
    compressor = bz2.BZ2Compressor(9)
    chunk = bytes(2**20)
    with open(path, "wb") as file:
        for _ in range(megabytes):
            file.write(compressor.compress(chunk))
        file.write(compressor.flush())


def _lying_stl(path: Path) -> None:
    """An 80-byte header, then a triangle count of 4 294 967 295, then one triangle."""
    path.write_bytes(b"\0" * 80 + struct.pack("<I", 2**32 - 1) + b"\0" * 50)


def _sparse(path: Path, size: int) -> None:
    with open(path, "wb") as file:
        file.truncate(size)


MESHES = {
    "bz2-bomb-512MiB": ("foot.stl.bz2", lambda p: _bz2_bomb(p, 512), "compressed"),
    "stl-billions-of-triangles": ("foot.stl", _lying_stl, "claims 4294967295 triangles"),
    "obj-20MiB": ("foot.obj", lambda p: _sparse(p, 20 * 2**20), "over 16.0 MiB"),
    "dae-20MiB": ("foot.dae", lambda p: _sparse(p, 20 * 2**20), "over 16.0 MiB"),
    "stl-200MiB": ("foot.stl", lambda p: _sparse(p, 200 * 2**20), "over 64.0 MiB"),
    "gltf": ("foot.gltf", lambda p: p.write_text("{}"), "is not read"),
}


@pytest.mark.parametrize("case", MESHES, ids=list(MESHES))
def test_hostile_mesh_is_reported_in_bounded_memory(case: str, tmp_path: Path) -> None:
    name, make, reason = MESHES[case]
    make(tmp_path / name)
    urdf = tmp_path / "robot.urdf"
    urdf.write_text(tiny_biped_urdf(foot_geometry=f'<mesh filename="{name}"/>'))
    result = run_cli("check", str(urdf), "--json", tmp_path=tmp_path)
    assert result.returncode == 0, result.stderr
    assert "Traceback" not in result.stderr
    report = json.loads(result.stdout)
    assert [m["uri"] for m in report["missing_meshes"]] == [name, name]  # left and right foot
    assert reason in report["missing_meshes"][0]["reason"]
    assert result.peak_rss_mb <= MAX_RSS_MB


def _limit_file_size() -> None:
    """In the child: files may not grow past 4 KiB, and passing the limit is an error (EFBIG),
    not a signal."""
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (4096, 4096))


def test_failed_write_leaves_the_previous_file_whole(tmp_path: Path) -> None:
    out = tmp_path / "motion.csv"
    good = "a good file, from an earlier run\n" * 30
    out.write_text(good)
    result = run_cli(
        "motion", "com_shift", "--dt", "0.05", "--out", str(out),
        tmp_path=tmp_path, preexec_fn=_limit_file_size,
    )  # fmt: skip
    assert_refused_in_one_line(result, "cannot write", "nothing was written")
    assert out.read_text() == good
    assert sorted(path.name for path in tmp_path.iterdir()) == ["motion.csv"]


def test_output_is_replaced_whole(tmp_path: Path) -> None:
    """Without a limit the same run replaces the file, and leaves no temporary file."""
    out = tmp_path / "motion.csv"
    out.write_text("old\n")
    result = run_cli("motion", "com_shift", "--dt", "0.05", "--out", str(out), tmp_path=tmp_path)
    assert result.returncode == 0, result.stderr
    lines = out.read_text().splitlines()
    assert lines[0].startswith("t [s],") and len(lines) > 10
    assert sorted(path.name for path in tmp_path.iterdir()) == ["motion.csv"]


def test_calibrate_output_to_a_device_is_refused(tmp_path: Path) -> None:
    measured = tmp_path / "m.csv"
    rows = ["frame,joint,q_cmd_deg,q_meas_deg,tau_Nm"]
    rows += [f"{k},knee,{10 + k},{10 + k - 1.5 * (k % 5)},{k % 5}" for k in range(40)]
    measured.write_text("\n".join(rows) + "\n")
    result = run_cli("calibrate", str(measured), "--out", "/dev/full", tmp_path=tmp_path)
    assert_refused_in_one_line(result, "/dev/full", "not a regular file")
