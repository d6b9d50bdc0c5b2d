"""A sweep over servo parts traded off on the parts' own axes, as a user runs it from the
command line: a user servo file named by the sweep file (`servo_files`) joins the choices and
reaches the Dask worker as its record; each point's servo mass is the catalogue's mass times
the leg joints, its cost the published price (the catalogue's or the user's; none for the
MX-64: said, and empty); the Pareto set is the one recomputed by brute force over the written rows.

The user's servo is the built-in MX-106 with another key, mass and a price: same motor model
and firmware, so its walk must simulate exactly as the MX-106's (same energy, same errors)
while its mass and cost are its own, which proves the record travelled to the worker whole.
"""

from __future__ import annotations

import csv
import json
import math
import pickle
from pathlib import Path

import numpy as np
import pytest

from app.core.robot.loading import load_robot
from app.core.servo.catalogue import load_catalogue
from app.core.servo.presets import uniform_preset
from app.core.sweeps.robot_variants import SweepSpecError
from app.core.sweeps.sampling import sweep_points
from app.core.sweeps.spec import SweepSpec, read_sweep_toml
from tests.core.test_sweep_pareto import brute_force
from tests.test_cli import run

REPO = Path(__file__).resolve().parents[1]
MASS_KG, PRICE = 0.2, 99.5
"""The user's servo: its mass and price (USD)."""


def user_mx106(key: str = "my106", mass: float = MASS_KG, price: float | None = PRICE) -> str:
    """The built-in MX-106 record under another key, mass and (optionally) a price."""
    text = (REPO / "robots" / "servos" / "mx106.toml").read_text()
    # the built-in's own price, currency and its source out: the user's (or none) instead
    text = "".join(line for line in text.splitlines(True) if not line.startswith("price"))
    text = text.replace('key = "mx106"', f'key = "{key}"')
    text = text.replace("mass_kg = 0.153", f"mass_kg = {mass}")
    if price is not None:
        text = text.replace(
            "identified = ", f'price = {price}\nprice_currency = "USD"\nidentified = '
        )
        text = text.replace("[sources]\n", '[sources]\nprice = "the workshop\'s invoice"\n')
    return text


def part_sweep(
    choices: tuple[str, ...], axis: str = "servo_mass_kg", servo_files: tuple[str, ...] = ()
) -> str:
    """A sweep file: dircon_biped over the servo parts `choices` (a grid), each point walked one
    step in the simulation, traded off on `axis` against the electrical energy; `servo_files`:
    the user's servo files it names (relative to it)."""
    files = f"servo_files = {json.dumps(list(servo_files))}\n" if servo_files else ""
    return f"""
robot = "dircon_biped"
sampling = "grid"
simulate = true
walk_steps = 1
{files}pareto = {{ {axis} = "min", electrical_energy_J = "min" }}
[gait]
knots = 14
[[parameter]]
name = "servo"
kind = "part"
choices = {json.dumps(list(choices))}
"""


SWEEP = part_sweep(("mx64", "mx106", "my106"), servo_files=("servos/mine.toml",))


def write_sweep(folder: Path, sweep: str = SWEEP, servo: str | None = None) -> Path:
    (folder / "servos").mkdir(exist_ok=True)
    (folder / "servos" / "mine.toml").write_text(user_mx106() if servo is None else servo)
    path = folder / "sweep.toml"
    path.write_text(sweep)
    return path


@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    folder = tmp_path_factory.mktemp("part_axes")
    spec_path, out = write_sweep(folder), folder / "results.csv"
    result = run(
        "sweep", str(spec_path), "--workers", "1", "--json", "--out", str(out), timeout_s=900
    )
    assert result.returncode == 0, result.stderr
    rows = {row["servo"]: row for row in csv.DictReader(out.open())}
    return json.loads(result.stdout), rows


def legs() -> int:
    return int(np.sum(uniform_preset(load_robot("dircon_biped")).enabled))


def test_each_points_servo_mass_is_the_catalogue_mass_on_every_leg_joint(swept):
    _report, rows = swept
    catalogue = load_catalogue()
    assert set(rows) == {"mx64", "mx106", "my106"}
    n = legs()
    assert n >= 4  # hips and knees at least
    for key, mass in (("mx64", catalogue["mx64"].mass_kg), ("mx106", 0.153), ("my106", MASS_KG)):
        assert float(rows[key]["servo_mass_kg"]) == pytest.approx(n * mass, rel=1e-12)


def test_cost_is_the_published_price_and_said_missing_where_there_is_none(swept):
    report, rows = swept
    assert float(rows["my106"]["servo_cost"]) == pytest.approx(legs() * PRICE, rel=1e-12)
    mx106 = load_catalogue()["mx106"].price  # the built-in's published list price
    assert float(rows["mx106"]["servo_cost"]) == pytest.approx(legs() * mx106, rel=1e-12)
    assert math.isnan(float(rows["mx64"]["servo_cost"]))  # no list price found for it
    assert any(n.startswith("servo_cost: no published price for mx64:") for n in report["notes"])


def test_the_users_servo_simulates_as_the_servo_it_copies(swept):
    _report, rows = swept
    mine, theirs = rows["my106"], rows["mx106"]
    assert mine["solved"] == theirs["solved"] == "True"
    for column in ("electrical_energy_J", "rms_joint_error_deg", "max_torso_error_deg"):
        assert float(mine[column]) == pytest.approx(float(theirs[column]), rel=1e-9), column
    assert float(mine["electrical_energy_J"]) > 0.0  # the leg servos drew energy
    # the stronger servo keeps more margin on the same planned points
    assert float(theirs["servo_margin"]) > float(rows["mx64"]["servo_margin"])


def test_the_pareto_set_is_the_brute_force_front_of_the_written_rows(swept):
    report, rows = swept
    order = sorted(rows.values(), key=lambda r: int(r["index"]))
    values = np.array([[float(r["servo_mass_kg"]), float(r["electrical_energy_J"])] for r in order])
    solved = np.array([r["solved"] == "True" and r["fell"] in ("0.0", "1.0") for r in order])
    values[~solved] = np.nan
    front = brute_force(values, ["min", "min"])
    expected = [int(r["index"]) for r, on in zip(order, front, strict=True) if on]
    assert report["pareto"] == expected
    assert [int(r["pareto"]) for r in order] == [int(int(r["index"]) in expected) for r in order]
    assert report["pareto_metrics"] == [["servo_mass_kg", "min"], ["electrical_energy_J", "min"]]


def test_the_points_carry_the_users_record_to_the_worker(tmp_path):
    spec = read_sweep_toml(write_sweep(tmp_path))
    points = pickle.loads(pickle.dumps(sweep_points(spec)))  # as Dask ships them
    by_servo = {p.simulation.part.servo: p.simulation.part for p in points}
    assert by_servo["mx106"].records == ()
    (record,) = by_servo["my106"].records
    assert (record.key, record.mass_kg, record.price) == ("my106", MASS_KG, PRICE)
    assert record.fit("m1") == load_catalogue()["mx106"].fit("m1")


@pytest.mark.parametrize(
    ("change", "says"),
    [
        (lambda s: s.replace("servos/mine.toml", "servos/none.toml"), "none.toml"),
        (lambda s: s.replace('"my106"]', '"yours"]'), "servo 'yours' is not a catalogue servo"),
        (
            lambda s: s.replace("servo_mass_kg", "servo_cost"),
            "servo_cost: no published price for mx64",
        ),
        (
            lambda s: (
                s.replace('choices = ["mx64", "mx106", "my106"]', 'choices = ["my106"]')
                .replace("servo_mass_kg", "servo_cost")
                .replace('servo_files = ["servos/mine.toml"]', 'servo_files = "servos/mine.toml"')
            ),
            "give a list of file paths",
        ),
    ],
)
def test_bad_servo_files_and_axes_are_refused_in_one_line(tmp_path, change, says):
    with pytest.raises(SweepSpecError, match=None) as refused:
        read_sweep_toml(write_sweep(tmp_path, change(SWEEP)))
    assert says in str(refused.value) and "\n" not in str(refused.value)


def test_a_bad_user_servo_file_is_refused_naming_its_field(tmp_path):
    broken = user_mx106().replace("mass_kg = 0.2", "mass_kg = -0.2")
    with pytest.raises(SweepSpecError) as refused:
        read_sweep_toml(write_sweep(tmp_path, servo=broken))
    assert "mass_kg" in str(refused.value) and "mine.toml" in str(refused.value)


def test_cost_with_every_servo_priced_is_accepted(tmp_path):
    sweep = part_sweep(("my106", "my107"), "servo_cost", ("servos/mine.toml",))
    servo = "[[servo]]\n" + user_mx106().replace("\n[", "\n[servo.") + "\n[[servo]]\n"
    servo += user_mx106("my107", 0.3, 120.0).replace("\n[", "\n[servo.")
    spec = read_sweep_toml(write_sweep(tmp_path, sweep, servo))
    assert spec.servos == ("my106", "my107")
    assert spec.pareto[0] == ("servo_cost", "min")


def test_a_project_keeps_a_part_sweep_with_its_users_servo_file(tmp_path):
    """The sweep's spec (the user's file's text with it, at the size limit and full of
    non-ASCII sources) and the parts' metrics (NaN cost included) come back from a project."""
    import dataclasses

    from app.core.projects.files import read_project, save_project
    from app.core.projects.project import Project
    from app.core.projects.robot_files import robot_source
    from app.core.sweeps.evaluate import PointResult
    from app.core.sweeps.part_parameters import MAX_USER_JSON_CHARS
    from app.core.sweeps.results import SweepRecord

    text = user_mx106()
    padding = "# " + "·" * 80 + "\n"  # 6 JSON characters each: the limit is on the JSON
    spare = MAX_USER_JSON_CHARS - len(json.dumps([{"name": "mine.toml", "text": text}]))
    text += padding * (spare // len(json.dumps(padding)[1:-1]))
    data = json.loads(json.dumps(SWEEP_DATA)) | {
        "user_servos": [{"name": "mine.toml", "text": text}]
    }
    point = PointResult(0, (1.0,), True, "solved", "", 0.2, 0.2, 3.0, 4.0, 1.0, 9, 0.3, 0.0, "h")
    point = dataclasses.replace(
        point, fell=0.0, servo_mass_kg=1.2, servo_cost=math.nan, electrical_energy_J=55.0,
        servo_margin=-0.25,
    )  # fmt: skip
    robot = load_robot("dircon_biped")
    project = Project(
        robot_source(robot), robot.q_neutral.copy(), sweep=SweepRecord.of(data, [point])
    )
    save_project(tmp_path / "p.bstudio", project)
    opened = read_project(tmp_path / "p.bstudio").sweep
    assert opened is not None and opened.spec() == project.sweep.spec()
    assert opened.spec().user_servos[0].text == text
    (back,) = opened.results
    assert (back.servo_mass_kg, back.electrical_energy_J, back.servo_margin) == (1.2, 55.0, -0.25)
    assert math.isnan(back.servo_cost)
    # past the limit: refused when the sweep is made, in one line
    data["user_servos"][0]["text"] = text + padding * 2
    with pytest.raises(SweepSpecError, match="characters as a project keeps them"):
        SweepSpec.from_mapping(data)


@pytest.mark.parametrize(
    ("user_servos", "words"),
    [
        ([{"name": "mine.toml", "text": "key = "}], "not valid TOML"),
        ([{"name": "mine.toml", "text": user_mx106().replace("mass_kg = 0.2", "mass_kg = nan")}],
         "mass_kg is nan"),
        ([{"name": "mine.toml", "text": user_mx106("mx106")}], "key 'mx106' is already used"),
        ([{"name": "mine.toml"}], "not a {name, text} table"),
        ("mine.toml", "user_servos is a list"),
    ],
)  # fmt: skip
def test_a_projects_sweep_with_a_hostile_servo_file_is_refused_naming_it(
    tmp_path, user_servos, words
):
    """A saved project whose sweep's user servo file was edited: refused on open, one line
    naming the sweep and what is wrong with the file."""
    import io
    import zipfile

    from app.core.projects.codec import ProjectError
    from app.core.projects.files import parse_project, save_project
    from app.core.projects.project import Project
    from app.core.projects.robot_files import robot_source
    from app.core.sweeps.evaluate import PointResult
    from app.core.sweeps.results import SweepRecord

    data = json.loads(json.dumps(SWEEP_DATA)) | {
        "user_servos": [{"name": "mine.toml", "text": user_mx106()}]
    }
    point = PointResult(0, (1.0,), False, "failed", "x", *[math.nan] * 5, 0, 0.0, 0.0, "")
    robot = load_robot("dircon_biped")
    project = Project(
        robot_source(robot), robot.q_neutral.copy(), sweep=SweepRecord.of(data, [point])
    )
    path = tmp_path / "p.bstudio"
    save_project(path, project)
    with zipfile.ZipFile(path) as archive:
        entries = {name: archive.read(name) for name in archive.namelist()}
    manifest = json.loads(entries["manifest.json"])
    manifest["project"]["sweep"]["spec_json"] = json.dumps(data | {"user_servos": user_servos})
    entries["manifest.json"] = json.dumps(manifest).encode()
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        for name, content in entries.items():
            archive.writestr(name, content)
    with pytest.raises(ProjectError) as refused:
        parse_project(buffer.getvalue(), "edited.bstudio")
    said = str(refused.value)
    assert "project.sweep" in said and words in said and "\n" not in said


SWEEP_DATA = {
    "robot": "dircon_biped",
    "sampling": "grid",
    "simulate": True,
    "walk_steps": 1,
    "pareto": {"servo_mass_kg": "min", "electrical_energy_J": "min"},
    "parameter": [{"kind": "part", "name": "servo", "choices": ["mx106", "my106"]}],
}
