"""Sweep files: good ones become points, hostile ones are refused with a message that says why."""

from __future__ import annotations

import math

import numpy as np
import pytest

from app.core.sweeps.robot_variants import SweepSpecError
from app.core.sweeps.sampling import sample_values, sweep_points, unit_samples
from app.core.sweeps.spec import MAX_POINTS, SweepSpec, read_sweep_toml


def spec(**top) -> dict:
    data = {
        "samples": 5,
        "parameter": [{"name": "step_length_m", "kind": "gait", "min": 0.1, "max": 0.3}],
    }
    data.update(top)
    return data


def param(name="step_length_m", kind="gait", lo=0.1, hi=0.3, **more) -> dict:
    return {"name": name, "kind": kind, "min": lo, "max": hi, **more}


@pytest.mark.parametrize(
    ("data", "words"),
    [
        (spec(parameter=[param(lo=math.nan)]), "finite"),
        (spec(parameter=[param(hi=math.inf)]), "finite"),
        (spec(samples=0), "at least 1"),
        (spec(samples=-3), "at least 1"),
        (spec(samples=10**9), f"limit of {MAX_POINTS}"),
        (
            spec(
                sampling="grid",
                parameter=[param(levels=200), param("H_s", lo=0.5, hi=1.0, levels=200)],
            ),
            f"limit of {MAX_POINTS}",
        ),
        (spec(parameter=[param("wings")]), "unknown gait parameter 'wings'"),
        (spec(parameter=[param("wings", kind="robot")]), "unknown robot parameter 'wings'"),
        (spec(parameter=[param(kind="hydraulic")]), "kind = 'hydraulic'"),
        (spec(parameter=[param(lo=0.3, hi=0.1)]), "min = 0.3 > max = 0.1"),
        (spec(parameter=[param(hi=2.0)]), "leaves what the planner accepts"),
        (spec(parameter=[param("knots", lo=5, hi=500)]), "leaves what the planner accepts"),
        (
            spec(parameter=[param("thigh_length_m", kind="robot", lo=0.3, hi=0.9)]),
            "leaves what the dircon_biped builder accepts",
        ),
        (
            spec(parameter=[param("compliance_deg_per_Nm", kind="servo", lo=0, hi=1)]),
            "only through the simulation: set simulate = true",
        ),
        (spec(servo={"dead_band_deg": 1.0}), "only through the simulation"),
        (spec(pareto={"sr": "min", "fell": "min"}), "pareto metric fell act(s) only"),
        (
            spec(simulate=True, parameter=[param("compliance", kind="servo", lo=0, hi=1)]),
            "unknown servo parameter 'compliance'",
        ),
        (
            spec(simulate=True, parameter=[param("dead_band_deg", kind="servo", lo=0, hi=45)]),
            "dead_band_deg range [0, 45] leaves [0, 10]",
        ),
        (spec(simulate=True, servo={"compliance_deg_per_Nm": -1}), "leaves [0, 20]"),
        (spec(simulate=True, servo={"compliance_deg_per_Nm": "stiff"}), "is not a number"),
        (spec(simulate="yes"), "is not a true or false"),
        (spec(simulate=True, walk_steps=0), "walk_steps = 0"),
        (spec(simulate=True, walk_steps=50), "walk_steps = 50"),
        (spec(parameter=[param(), param()]), "given twice"),
        (spec(parameter=[]), "no [[parameter]]"),
        (spec(parameter=[param("baseline", lo=0, hi=1)]), "unknown gait parameter 'baseline'"),
        (spec(pareto={"sr": "min", "speed": "max"}), "pareto metric 'speed'"),
        (spec(pareto={"sr": "least", "energy_J": "min"}), "give 'min' or 'max'"),
        (spec(pareto={"sr": "min"}), "exactly two"),
        (spec(robot="/etc/passwd"), "built-in robot"),
        (spec(sampling="sobol"), "sampling = 'sobol'"),
        (spec(samples=True), "is not a whole number"),
        (spec(gait={"knots": 2}), "at least"),
        (spec(gait={"wings": 2}), "unknown key"),
        (spec(parameter=[param(lo="0.1")]), "is not a number"),
        (spec(extra=1), "unknown key(s) extra"),
        (spec(parameter=[param(levels=0)]), "levels = 0"),
        (spec(start="warm"), "start = 'warm'"),
        (spec(package_roots=["/ws/src"]), "for a robot loaded from a .urdf file"),
        (spec(feet=["l", "r"]), "for a robot loaded from a .urdf file"),
        (spec(robot="mine.urdf", package_roots="/ws/src"), "is not a list"),
        (spec(robot="mine.urdf", package_roots=[3]), "is not a text"),
        (spec(robot="mine.urdf", package_roots=["/r"] * 17), "at most 16"),
        (spec(robot="mine.urdf", feet="l_sole"), "is not a list"),
        (spec(robot="mine.urdf", feet=["l_sole"]), "the left and the right foot link"),
        (spec(robot="mine.urdf", feet=["l_sole", ""]), "the left and the right foot link"),
    ],
)
def test_hostile_specs_are_refused_with_the_reason(data, words):
    with pytest.raises(SweepSpecError) as info:
        SweepSpec.from_mapping(data)
    assert words in str(info.value)


def test_servo_parameters_reach_each_points_simulation_setup():
    data = spec(
        simulate=True,
        walk_steps=3,
        servo={"dead_band_deg": 1.5},
        parameter=[
            param(),
            param("compliance_deg_per_Nm", kind="servo", lo=0.5, hi=4.0),
            param("compensation", kind="servo", lo=0, hi=1),
        ],
    )
    points = sweep_points(SweepSpec.from_mapping(data))
    for point in points:
        setup = point.simulation
        assert setup is not None and setup.walk_steps == 3 and setup.dead_band_deg == 1.5
        assert setup.compliance_deg_per_Nm == point.values[1]
        assert point.values[2] in (0.0, 1.0)  # a switch is rounded, like knots
        assert setup.compensation == (point.values[2] == 1.0)
    assert {p.values[2] for p in points} == {0.0, 1.0}  # latin strata cover both halves
    assert sweep_points(SweepSpec.from_mapping(spec()))[0].simulation is None


def test_a_toml_file_with_nan_is_refused_before_it_becomes_a_spec(tmp_path):
    path = tmp_path / "sweep.toml"
    path.write_text('[[parameter]]\nname = "H_s"\nmin = nan\nmax = 1.0\n')
    with pytest.raises(SweepSpecError, match="finite|nan"):
        read_sweep_toml(path)


@pytest.mark.parametrize("name", ["sweep_dircon.toml", "sweep_servos.toml"])
def test_the_example_sweep_files_read(name):
    from pathlib import Path

    example = Path(__file__).resolve().parents[2] / "examples" / name
    loaded = read_sweep_toml(example)
    assert loaded.n_points == len(sweep_points(loaded))


def test_latin_hypercube_puts_one_point_in_every_stratum_of_every_parameter():
    n = 17
    s = SweepSpec.from_mapping(
        spec(sampling="latin", samples=n, seed=3, parameter=[param(), param("H_s", lo=0.5, hi=1.0)])
    )
    unit = unit_samples(s)
    assert unit.shape == (n, 2)
    for column in unit.T:
        assert sorted(np.floor(column * n).astype(int)) == list(range(n))
    again = unit_samples(s)
    np.testing.assert_array_equal(unit, again)  # the seed fixes the sample


def test_grid_is_the_product_of_evenly_spaced_levels():
    s = SweepSpec.from_mapping(
        spec(
            sampling="grid",
            parameter=[param(levels=3), param("knots", lo=10, hi=16, levels=4)],
        )
    )
    values = sample_values(s)
    expected = [(a, b) for a in (0.1, 0.2, 0.3) for b in (10, 12, 14, 16)]
    np.testing.assert_allclose(values, expected)
    points = sweep_points(s)
    assert [p.settings.knots for p in points[:4]] == [10, 12, 14, 16]
    assert all(isinstance(p.settings.knots, int) for p in points)


def test_random_points_lie_in_their_ranges_and_carry_the_fixed_settings():
    s = SweepSpec.from_mapping(
        spec(
            sampling="random",
            samples=50,
            seed=1,
            gait={"knots": 12, "K0": 3.0},
            parameter=[param(), param("thigh_length_m", kind="robot", lo=0.35, hi=0.45)],
        )
    )
    points = sweep_points(s)
    assert len(points) == 50
    for p in points:
        assert 0.1 <= p.settings.step_length_m <= 0.3
        assert p.settings.knots == 12 and p.settings.K0 == 3.0
        ((name, value),) = p.robot.values
        assert name == "thigh_length_m" and 0.35 <= value <= 0.45
        assert p.values == (p.settings.step_length_m, value)


def test_a_urdf_file_is_swept_on_gait_and_servo_only(tmp_path):
    """A sweep of a URDF file (a robot loaded from a file, not a built-in's own) takes gait
    parameters, refuses robot ones naming why, and its points carry the file as it is."""
    import shutil

    from app.core.sweeps.robot_variants import sweep_robot_of
    from robots.catalogue import BUILTIN_ROBOTS

    builtin = BUILTIN_ROBOTS["servo_biped"].urdf_path
    copy = tmp_path / "mine.urdf"
    shutil.copy(builtin, copy)
    assert sweep_robot_of(builtin) == "servo_biped" and sweep_robot_of("dircon_biped") == (
        "dircon_biped"
    )
    assert sweep_robot_of(copy) == str(copy)
    checked = SweepSpec.from_mapping(spec(robot=str(copy)))
    points = sweep_points(checked)
    assert {p.robot.robot for p in points} == {str(copy)} and not points[0].robot.values
    with pytest.raises(SweepSpecError, match="no sweepable robot parameters"):
        SweepSpec.from_mapping(spec(robot=str(copy), parameter=[param("thigh_length_m", "robot")]))


def test_a_urdf_sweep_loads_its_robot_as_the_studio_did(tmp_path):
    """package_roots and feet (the studio's --package-root and --feet) travel with every point
    to where a worker loads the robot: a mesh found only in the package folder is found, and
    the feet are the named links, not the ones detection would pick."""
    import trimesh

    from robots.catalogue import BUILTIN_ROBOTS

    packages = tmp_path / "packages"
    (packages / "mypkg" / "meshes").mkdir(parents=True)
    trimesh.creation.icosphere(1, 0.03).export(packages / "mypkg" / "meshes" / "head.stl")
    urdf = BUILTIN_ROBOTS["servo_biped"].urdf_path.read_text(encoding="utf-8")
    urdf = urdf.replace('"left_foot"', '"pad_a"').replace('"right_foot"', '"pad_b"')
    head = (
        '<visual><geometry><mesh filename="package://mypkg/meshes/head.stl"/></geometry></visual>'
    )
    last = urdf.rindex("<visual>")
    (tmp_path / "desc").mkdir()
    path = tmp_path / "desc" / "renamed.urdf"
    path.write_text(urdf[:last] + head + urdf[last:], encoding="utf-8")

    plain = sweep_points(SweepSpec.from_mapping(spec(robot=str(path))))[0].robot.load()
    assert plain.missing_meshes  # no package root: the package is not found
    assert [foot.link for foot in plain.feet] != ["pad_a", "pad_b"]  # detection's choice

    told = SweepSpec.from_mapping(
        spec(robot=str(path), package_roots=[str(packages)], feet=["pad_a", "pad_b"])
    )
    assert told.package_roots == (str(packages),) and told.feet == ("pad_a", "pad_b")
    points = sweep_points(told)
    for point in points:
        assert point.robot.package_roots == told.package_roots
        assert point.robot.feet == told.feet
    robot = points[0].robot.load()
    assert not robot.missing_meshes
    assert [foot.link for foot in robot.feet] == ["pad_a", "pad_b"]
