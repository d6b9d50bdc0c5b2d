"""Issue 24 item 3: a project's arrays are held once while it is read and saved. A project whose
arrays are as large as a project may hold (a motion of MAX_SAMPLES samples, ~43 MB on
servo_biped; stored, and deflated into a small file) is read with
peak memory ≤ 2 × its arrays' size above what the process used before: earlier, the file was
read whole, each entry read into bytes and then copied into its array (3 × for a stored file,
2.1 × for a deflated one), and a save built the archive in memory (4 × with the project held).

The arrays' size is taken from the file's zip directory (the `.npy` entries' sizes), not from
the reader; peak memory is the kernel's (VmHWM; ru_maxrss of a run through the CLI) of a fresh process."""

from __future__ import annotations

import json
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

from app.core.budgets import MAX_SAMPLES
from app.core.motions.library import run_motion
from app.core.motions.trajectory import Trajectory
from app.core.projects.files import save_project
from app.core.projects.project import Project
from app.core.projects.robot_files import robot_source
from app.core.robot.loading import load_robot
from tests.hostile.cli_runner import REPO, assert_refused_in_one_line, run_cli

ARRAYS_MB = 250
"""How large the big project's arrays would be, were a motion not capped at MAX_SAMPLES
samples (the cap makes the largest accepted project's arrays ~43 MB on servo_biped)."""

_MEASURE = """
import json, resource, sys
import numpy as np
from app.core.projects.files import read_project, save_project
from app.core.projects.project import check_fits
from app.core.projects.robot_files import load_project_robot
from app.config import StudioConfig

def rss_mb():  # resident now
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * resource.getpagesize() / 2**20

def peak_mb():  # this process's own high-water mark (ru_maxrss would carry over the
    with open("/proc/self/status") as f:  # RSS of the process it was forked from)
        return next(int(l.split()[1]) for l in f if l.startswith("VmHWM:")) / 1024

read_project(sys.argv[3])  # warm: what a first read imports is not the project's memory
start = rss_mb()
project = read_project(sys.argv[1])
read_peak = peak_mb() - start
robot = load_project_robot(project.robot, StudioConfig().uploads_dir)
check_fits(project, robot)  # an accepted project
save_project(sys.argv[2], project)
saved_peak = peak_mb() - start
again = read_project(sys.argv[2])
same = bool(np.array_equal(again.motion.q, project.motion.q))
print(json.dumps({"read_mb": read_peak, "saved_mb": saved_peak, "same": same}))
"""


def long_motion(robot, n_samples: int) -> Trajectory:
    """com_shift repeated to `n_samples` samples (a long, legitimate motion)."""
    base = run_motion(robot, "com_shift").trajectory
    reps = -(-n_samples // base.n_samples)

    def tiled(array: np.ndarray) -> np.ndarray:
        return np.tile(array, (reps,) + (1,) * (array.ndim - 1))[:n_samples]

    return Trajectory(
        "long",
        base.joint_names,
        np.arange(n_samples) * base.dt,
        tiled(base.q),
        tiled(base.v),
        tiled(base.a),
        tiled(base.contacts),
    )


def arrays_mb(path: Path) -> float:
    """The project's arrays' size, from its zip directory."""
    with zipfile.ZipFile(path) as archive:
        return sum(i.file_size for i in archive.infolist() if i.filename.endswith(".npy")) / 2**20


@pytest.fixture(scope="module")
def big(tmp_path_factory) -> dict:
    robot = load_robot("servo_biped")
    per_sample = 8 * (1 + robot.model.nq + 2 * robot.model.nv) + 2
    # As long as a project may hold (MAX_SAMPLES): the largest accepted project.
    motion = long_motion(robot, min(ARRAYS_MB * 2**20 // per_sample, MAX_SAMPLES))
    expected_mb = motion.n_samples * per_sample / 2**20
    folder = tmp_path_factory.mktemp("big")
    stored, deflated, misfit = folder / "stored.bstudio", folder / "deflated.bstudio", folder / "misfit.bstudio"  # fmt: skip
    project = Project(robot=robot_source(robot), q=motion.q[3], motion=motion)
    save_project(stored, project)
    with zipfile.ZipFile(stored) as source, zipfile.ZipFile(deflated, "w") as target:
        for info in source.infolist():
            target.writestr(info.filename, source.read(info), zipfile.ZIP_DEFLATED)
    save_project(misfit, Project(robot=robot_source(robot), q=motion.q[3][:-1], motion=motion))
    short = run_motion(robot, "com_shift").trajectory
    small = folder / "small.bstudio"  # the same, with a short motion and a pose that does not fit
    save_project(small, Project(robot=robot_source(robot), q=short.q[3][:-1], motion=short))
    return {
        "stored": stored,
        "deflated": deflated,
        "misfit": misfit,
        "small": small,
        "mb": expected_mb,
    }


@pytest.mark.parametrize("kind", ["stored", "deflated"])
def test_reading_and_saving_a_large_project_holds_its_arrays_once(big, kind, tmp_path) -> None:
    path = big[kind]
    size = arrays_mb(path)
    assert size > 0.9 * big["mb"]
    run = subprocess.run(
        [sys.executable, "-c", _MEASURE, str(path), str(tmp_path / "again.bstudio"), str(big["small"])],
        capture_output=True, text=True, cwd=REPO, timeout=600, check=False,
    )  # fmt: skip
    assert run.returncode == 0, run.stderr
    measured = json.loads(run.stdout)
    print(
        f"{kind} ({path.stat().st_size / 2**20:.1f} MB file), arrays {size:.0f} MB: "
        f"read peak +{measured['read_mb']:.0f} MB ({measured['read_mb'] / size:.2f}×), "
        f"read + save peak +{measured['saved_mb']:.0f} MB ({measured['saved_mb'] / size:.2f}×)"
    )
    assert measured["same"]
    assert measured["read_mb"] <= 2 * size
    assert measured["saved_mb"] <= 2 * size


def test_a_cli_run_on_a_large_project_peaks_within_twice_its_arrays(big, tmp_path) -> None:
    # The pose does not fit the robot: the command reads the whole project, then refuses it
    # in one line (its torques are not computed), so the peak is the reading's.
    size = arrays_mb(big["misfit"])
    runs = {
        name: run_cli("feedforward", str(big[name]), tmp_path=tmp_path)
        for name in ("small", "misfit")
    }
    for run in runs.values():
        assert_refused_in_one_line(run, "the pose has 18 values, not 19")
    grew = runs["misfit"].peak_rss_mb - runs["small"].peak_rss_mb
    print(f"feedforward: arrays {size:.0f} MB, peak +{grew:.0f} MB ({grew / size:.2f}×)")
    assert grew <= 2 * size
