"""The repository tests itself: a plain `git clone`, with nothing beside it, passes a sample of
the suite that reads the third-party robots (vendored under tests/third_party) and runs the
CLI on hostile inputs. Only committed files are in a clone, so a test data file that was
never added, or a path to a sibling folder, fails here."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SAMPLE = (
    "tests/core/test_real_robots.py::test_roban_feet_are_the_last_leg_links",
    "tests/core/test_real_robots.py::test_sigmaban_feet_and_fk_against_pinocchio_parser",
    "tests/core/test_uploads.py",
    "tests/hostile/test_hostile_uploads.py",
    "tests/hostile/test_hostile_cli.py::test_check_refuses_in_one_line[fifo]",
)


@pytest.mark.skipif(shutil.which("git") is None, reason="needs git")
def test_a_bare_clone_passes_a_sample_of_the_suite(tmp_path: Path) -> None:
    clone = tmp_path / "checkout"
    subprocess.run(
        ["git", "clone", "--quiet", "--no-hardlinks", str(REPO), str(clone)],
        check=True,
        capture_output=True,
        timeout=300,
    )
    assert sorted(p.name for p in tmp_path.iterdir()) == ["checkout"]  # nothing beside it
    assert (clone / "tests" / "third_party" / "roban_s14" / "urdf" / "robanS14.urdf").is_file()
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PYTEST", "ROS_"))}
    env.pop("PYTHONPATH", None)
    result = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:randomly", *SAMPLE],
        cwd=clone,
        env=env,
        capture_output=True,
        text=True,
        timeout=900,
        check=False,
    )
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-2000:]
    assert " passed" in result.stdout and "error" not in result.stdout.splitlines()[-1]
    # the clone's own code was tested, not this checkout's
    where = subprocess.run(
        [sys.executable, "-c", "import app; print(app.__file__)"],
        cwd=clone,
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    assert Path(where.stdout.strip()).resolve().is_relative_to(clone.resolve())
