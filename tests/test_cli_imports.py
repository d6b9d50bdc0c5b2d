"""Each command loads the libraries it uses and no other's: the parser alone imports no
command's implementation, a robot of primitive shapes loads without trimesh (nor scipy), casadi
comes with gait commands only, mujoco with simulation, dask with sweeps (issue 23: ~60 CLI tests
each paid every import, ~2 CPU-s, before running anything)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
HEAVY = ("numpy", "pinocchio", "placo", "trimesh", "scipy", "casadi", "mujoco", "dask", "viser")

_RUN_IN_TURN = """
import contextlib, io, json, sys
from app.cli import main
loaded = []
for argv in json.loads(sys.argv[1]):
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        try:
            status = main(argv)
        except SystemExit as stop:
            status = stop.code
    loaded.append([status, [name for name in json.loads(sys.argv[2]) if name in sys.modules]])
print(json.dumps(loaded))
"""


def test_each_command_imports_only_what_it_uses(tmp_path):
    """The commands run in turn in one process, each needing at least what the one before did:
    a library loaded by then was loaded by that command or an earlier one."""
    motion, bad_plan = tmp_path / "shift.csv", tmp_path / "plan.toml"
    bad_plan.write_text("K3 = 1.0\n")  # refused once the gait's settings are read
    commands = [  # (argv, the libraries it may have loaded by its end)
        (["--help"], ()),
        (["servos", "--json"], ("numpy",)),
        (["check", "servo_biped", "--json"], ("numpy", "pinocchio")),
        (
            ["motion", "com_shift", "--dt", "0.1", "--out", str(motion)],
            ("numpy", "pinocchio", "placo"),
        ),
        (
            ["feedforward", str(motion), "--out", str(tmp_path / "tau.csv")],
            ("numpy", "pinocchio", "placo", "scipy"),
        ),
        (["plan", "--config", str(bad_plan)], ("numpy", "pinocchio", "placo", "scipy", "casadi")),
    ]
    argvs = [argv for argv, _ in commands]
    result = subprocess.run(
        [sys.executable, "-c", _RUN_IN_TURN, json.dumps(argvs), json.dumps(HEAVY)],
        capture_output=True,
        text=True,
        cwd=REPO,
        check=False,
    )
    assert result.returncode == 0, result.stderr
    runs = json.loads(result.stdout)
    statuses = [status for status, _ in runs]
    assert statuses == [0, 0, 0, 0, 0, 1], statuses  # the bad plan.toml is refused: the point
    for (argv, allowed), (_, loaded) in zip(commands, runs, strict=True):
        assert set(loaded) <= set(allowed), (argv, sorted(set(loaded) - set(allowed)))
