"""`biped-studio serve` keeps its access link across restarts: two starts in the same data
folder print the same link, `--new-token` prints a new one (the old one is then refused), the
token file is readable by the user only; a damaged token file gets one line and a new link."""

from __future__ import annotations

import dataclasses
import os
import stat
import subprocess
import sys
import urllib.error
import urllib.request
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from tests.test_projects_serve import ROOT, _free_port, lines_until_ready


@dataclasses.dataclass
class Run:
    process: subprocess.Popen
    stderr: str = ""
    """What the process wrote to stderr (once stopped)."""


@contextmanager
def serve(data: Path, port: int, *args: str) -> Iterator[Run]:
    """`python -m app serve` (with its token) on `port`, data in `data`; stopped at the end."""
    env = {**os.environ, "BIPED_STUDIO_DATA": str(data)}
    process = subprocess.Popen(
        [sys.executable, "-m", "app", "serve", "--port", str(port), "--fresh", *args],
        cwd=ROOT,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    run = Run(process)
    try:
        yield run
    finally:
        if process.poll() is None:
            process.terminate()
        run.stderr = process.communicate()[1]


def _link(run: Run) -> str:
    return lines_until_ready(run.process)[-1].strip()


def _status(url: str) -> int:
    try:
        with urllib.request.urlopen(url) as answer:
            return int(answer.status)
    except urllib.error.HTTPError as error:
        return int(error.code)


def test_the_link_survives_a_restart_and_new_token_rotates_it(tmp_path):
    """Four starts of a real `serve` in one data folder."""
    data, port = tmp_path / "data", _free_port()
    with serve(data, port) as first:
        link = _link(first)
        assert "?token=" in link and _status(link) == 200
    token_file = data / "access-token"
    assert stat.S_IMODE(token_file.stat().st_mode) == 0o600
    assert stat.S_IMODE(data.stat().st_mode) == 0o700
    assert link.endswith("?token=" + token_file.read_text().strip())

    with serve(data, port) as second:
        assert _link(second) == link  # the tabs opened on it keep working
        assert _status(link) == 200

    with serve(data, port, "--new-token") as third:
        new_link = _link(third)
        assert new_link != link and "?token=" in new_link
        assert _status(link) == 401 and _status(new_link) == 200
    assert "Made a new access token" in third.stderr

    # A token file other users could read may be known to them: replaced, said in one line.
    os.chmod(token_file, 0o644)
    with serve(data, port) as fourth:
        fourth_link = _link(fourth)
    assert fourth_link not in (link, new_link)
    warnings = [line for line in fourth.stderr.splitlines() if "access token" in line]
    assert len(warnings) == 1 and "mode 0644" in warnings[0], warnings
    assert stat.S_IMODE(token_file.stat().st_mode) == 0o600
