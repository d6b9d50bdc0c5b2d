"""The Servos folder on a real studio: a part per joint and what follows from it (k = 1/K from the
motor law's closed form), *Size servos* against a brute force over the catalogue, the part's
law in the simulation with its energy line, the parts kept by a project and refused when
hostile, and Undo taking a part change back."""

from __future__ import annotations

import math

import numpy as np
import pytest

from app.core.projects.codec import ProjectError
from app.core.projects.files import read_project, write_project
from app.core.projects.project import check_fits
from app.core.servo.choice import JointServo
from app.core.servo.edits import SetK
from app.core.simulation.part_law import PartLaw
from app.studio.servo_parts import catalogue
from tests.kp_brute_force import studio_sizing_pairs
from tests.studio.conftest import wait_for_signal, with_stand_torques


@pytest.fixture
def studio(studio):
    """The conftest's studio with the one-leg stand and its torques (each test its own)."""
    return with_stand_torques(studio)


def closed_form_compliance_deg_per_Nm(key: str, kp: float | None = None) -> float:
    """1/K with K = kt·vin·error_gain·kp/R from the record's m1 fit and firmware (issue 27)."""
    record = catalogue()[key]
    fit, firmware = record.fit("m1"), record.firmware
    assert fit is not None and firmware is not None
    stiffness = (
        fit.motor.kt_Nm_per_A
        * firmware.vin_V
        * firmware.error_gain
        * (firmware.kp if kp is None else kp)
        / fit.motor.R_ohm
    )
    return math.degrees(1.0 / stiffness)


def pick(studio, joint: str, key: str) -> None:
    panel = studio.servo_rooms.servos.panel
    panel.joint.value = joint
    label = next(lab for lab in panel.servo.options if lab.startswith(key + " "))
    panel.servo.value = label


def test_a_part_sets_k_and_the_virtual_servo_to_its_compliance(studio):
    robot, session = studio.state.robot, studio.servo_rooms.servos
    joint = robot.joint_names[3]
    i = robot.joint_names.index(joint)
    before = studio.state.work.coefficients
    pick(studio, joint, "mx64")
    coefficients, parts = studio.state.work.coefficients, studio.state.work.parts
    assert parts is not None and parts.joint(joint).servo == "mx64"
    assert session.panel.servo.value.startswith("mx64 ")  # the panel shows the part
    expected = closed_form_compliance_deg_per_Nm("mx64")
    assert coefficients.servo.compliance_deg_per_Nm[i] == pytest.approx(expected, rel=1e-12)
    assert coefficients.params.k_deg_per_Nm[i] == pytest.approx(expected, rel=1e-12)
    others = np.arange(robot.n_actuated) != i
    np.testing.assert_array_equal(
        coefficients.servo.compliance_deg_per_Nm[others],
        before.servo.compliance_deg_per_Nm[others],
    )
    assert f"{expected:.3g}" in session.panel.stiffness.content
    # kp halved: K halves, the compliance doubles.
    session.panel.settings["kp"].value = float(catalogue()["mx64"].firmware.kp) / 2
    assert studio.state.work.coefficients.params.k_deg_per_Nm[i] == pytest.approx(
        closed_form_compliance_deg_per_Nm("mx64", catalogue()["mx64"].firmware.kp / 2)
    )
    # k edited on this part's joint stays when another joint gets a part (only the joints
    # whose servo changed take k = 1/K).
    studio.servo_rooms.compensation.edit(SetK(joint, 2.5))
    pick(studio, robot.joint_names[5], "mx106")
    assert studio.state.work.coefficients.params.k_deg_per_Nm[i] == 2.5
    session.panel.joint.value = joint
    assert "eq 7's k is 2.5" in session.panel.stiffness.content
    # A kp outside the firmware's range: one line, the last good choice kept.
    good = studio.state.work.parts
    session.panel.settings["kp"].value = 1.0e6
    assert studio.state.work.parts is good
    assert "kp" in session.panel.status.content


def test_size_servos_picks_the_lightest_that_holds_as_a_brute_force_does(studio):
    robot, session = studio.state.robot, studio.servo_rooms.servos
    session.panel.margin.value = 0.2
    sizing = wait_for_signal(session.sized, lambda: session.size_servos())
    assert not isinstance(sizing, str), sizing
    _, works = session.last
    (work,) = works.values()
    parts = studio.state.work.parts
    pairs = studio_sizing_pairs(studio, 0.2)
    for name, (expected, kp) in zip(robot.joint_names, pairs, strict=True):
        expected = expected or ""
        assert (parts.joint(name).servo, parts.joint(name).kp) == (expected, kp), name
        if expected:
            assert f"{name}: **{expected}**" in session.panel.sizing.content
            if catalogue()[expected].kp_law:
                assert f", kp {kp:g} (sag" in session.panel.sizing.content
            else:  # rated by a continuous point (a PH42-020 hip roll): stiffness stated
                assert kp is None and parts.joint(name).stiffness_Nm_per_rad is not None
        else:
            assert f"{name}: **no servo holds it**" in session.panel.sizing.content
    # The torque–speed plot of a sized joint: every planned point, over its servo's envelope,
    # whose drive line meets ω = 0 at the stall torque kt·vin·max_pwm/R (capped by kt·I_lim).
    j, name = next((j, n) for j, n in enumerate(robot.joint_names) if parts.joint(n).servo)
    session.panel.joint.value = name
    x, drive, brake, points = session.panel.plot.data
    record = session.records[parts.joint(name).servo]
    fit, firmware = record.fit("m1"), record.firmware
    stall = fit.motor.kt_Nm_per_A * firmware.vin_V * firmware.max_pwm / fit.motor.R_ohm
    if firmware.current_limit_A is not None:
        stall = min(stall, fit.motor.kt_Nm_per_A * firmware.current_limit_A)
    at_zero = np.flatnonzero((x == 0.0) & np.isfinite(drive))
    assert drive[at_zero[0]] == pytest.approx(stall) and brake[at_zero[0]] == pytest.approx(-stall)
    shown = np.isfinite(points)
    np.testing.assert_array_equal(np.sort(points[shown]), np.sort(work.torque_Nm[:, j]))
    np.testing.assert_array_equal(np.sort(x[shown]), np.sort(work.speed_rad_s[:, j]))


def test_the_simulation_runs_the_parts_and_says_their_energy(studio):
    robot = studio.state.robot
    joint = robot.joint_names[3]
    pick(studio, joint, "mx106")
    studio.servo_rooms.servos.panel.battery.value = 10.0
    record = wait_for_signal(
        studio.state.work.on_simulation, lambda: studio.servo_rooms.simulation.simulate()
    )
    law = record.run.job.inputs[0].law
    assert isinstance(law, PartLaw)
    assert law.has_part is not None and list(np.flatnonzero(law.has_part)) == [3]
    energy = record.run.results["with compensation"].energy
    assert energy is not None
    assert np.all(energy.electrical_J[np.arange(robot.n_actuated) != 3] == 0.0)
    text = studio.servo_rooms.simulation.panel.verdict.content
    assert "**Energy**" in text and "10 Wh pack lasts" in text


def test_a_project_keeps_the_parts_and_refuses_hostile_ones(studio, tmp_path):
    robot = studio.state.robot
    joint = robot.joint_names[2]
    pick(studio, joint, "mx64")
    studio.servo_rooms.servos.panel.settings["dead_band_deg"].value = 0.5
    assert studio.project.save_as(str(tmp_path / "parts.bstudio"))
    project = read_project(tmp_path / "parts.bstudio")
    assert project.servo_parts.joint(joint) == JointServo("mx64", dead_band_deg=0.5)
    studio.servo_rooms.servos.panel.joint.value = joint
    studio.servo_rooms.servos.panel.servo.value = "ideal servo"
    assert studio.state.work.parts.joint(joint).servo == ""
    assert studio.project.open(str(tmp_path / "parts.bstudio"))
    assert studio.state.work.parts.joint(joint) == JointServo("mx64", dead_band_deg=0.5)
    i = robot.joint_names.index(joint)
    assert studio.state.work.coefficients.servo.backlash_deg[i] == 0.5
    for hostile, field in (
        (JointServo("mx64", kp=-3.0), "kp"),
        (JointServo("nope"), "not in the catalogue"),
        (JointServo("xh540_v270"), "no identified motor model"),
        (JointServo("mx64", dead_band_deg=400.0), "dead_band_deg"),
    ):
        bad = project.servo_parts.with_joint(joint, hostile)
        with pytest.raises(ProjectError, match=field):
            check_fits(_replace(project, servo_parts=bad), studio.state.robot)
    for bounds, words in (
        ({"stand_margin": -1.0}, "stand margin is -1"),
        ({"max_sag_deg": 1e9}, "max sag is 1e[+]09°"),
    ):
        bad = _replace(project.servo_parts, **bounds)
        with pytest.raises(ProjectError, match=f"project.servo_parts: {words}"):
            check_fits(_replace(project, servo_parts=bad), studio.state.robot)
    # Written and read back: refused on open with one line, the work untouched.
    path = tmp_path / "hostile.bstudio"
    with open(path, "wb") as file:
        bad = project.servo_parts.with_joint(joint, JointServo("mx64", kp=-3.0))
        write_project(file, _replace(project, servo_parts=bad))
    before = studio.state.work.parts
    assert not studio.project.open(str(path))
    assert "kp" in studio.project.last_error
    assert studio.state.work.parts is before


def _replace(project, **changes):
    import dataclasses

    return dataclasses.replace(project, **changes)


def test_undo_takes_a_part_change_back(studio):
    robot = studio.state.robot
    joint = robot.joint_names[4]
    i = robot.joint_names.index(joint)
    studio.project.autosave.now()  # the work before: a step
    before = studio.state.work.coefficients.servo.compliance_deg_per_Nm[i]
    pick(studio, joint, "mx106")
    studio.project.autosave.now()
    assert studio.state.work.parts.joint(joint).servo == "mx106"
    assert studio.project.undo()
    assert studio.state.work.parts.joint(joint).servo == ""
    assert studio.state.work.coefficients.servo.compliance_deg_per_Nm[i] == before
    assert f"Undid: servo {joint} mx106" in studio.project.panel.status.content
    assert studio.project.redo()
    assert studio.state.work.parts.joint(joint).servo == "mx106"


def _older_with_an_m6_knee(path, tmp_path, knee: int):
    """A copy of the project at `path` as a file saved before the sizing bounds were kept (its
    servo_parts without stand_margin and max_sag_deg), joint `knee` running the m6 fit."""
    import json
    import zipfile

    with zipfile.ZipFile(path) as archive:
        entries = {name: archive.read(name) for name in archive.namelist()}
    manifest = json.loads(entries["manifest.json"])
    parts = manifest["project"]["servo_parts"]
    del parts["stand_margin"], parts["max_sag_deg"]
    parts["joints"][knee]["friction_model"] = "m6"
    entries["manifest.json"] = json.dumps(manifest).encode()
    old = tmp_path / "old.bstudio"
    with zipfile.ZipFile(old, "w") as archive:
        for name, content in entries.items():
            archive.writestr(name, content)
    return old


def test_size_servos_takes_the_bounds_and_each_joints_fit_and_a_project_keeps_them(
    studio, tmp_path
):
    """The stand margin and largest sag beside *Size servos*: kept with the parts (the
    coefficients and simulation untouched), a bad one refused in one line with the last good
    value kept, used by the sizing as the brute force uses them, saved and opened with the
    project. A file saved before they were kept opens with the defaults; its knee running the
    m6 fit is sized on m6 and stays on it: K = kt·vin·error_gain·kp/R with the m6 file's kt and
    R (read here), the other joints on m1."""
    import json

    from app.core.servo.catalogue import BAM_PARAMS_DIR
    from app.core.servo.kp_sizing import MAX_SAG_DEG, STAND_MARGIN

    robot, session = studio.state.robot, studio.servo_rooms.servos
    panel = session.panel
    coefficients = studio.state.work.coefficients
    studio.project.autosave.now()  # the work before: a step
    panel.stand_margin.value = 1.0
    panel.max_sag.value = 1.5
    parts = studio.state.work.parts
    assert (parts.stand_margin, parts.max_sag_deg) == (1.0, 1.5)
    assert studio.state.work.coefficients is coefficients  # nothing follows until a sizing
    for handle, bad, words in (
        (panel.stand_margin, -1.0, "stand margin is -1; give a number in [0, 10]"),
        (panel.stand_margin, 50.0, "stand margin is 50; give a number in [0, 10]"),
        (panel.max_sag, 0.0, "max sag is 0°; give a number of degrees in (0, 90]"),
        (panel.max_sag, 120.0, "max sag is 120°"),
    ):
        handle.value = bad
        assert studio.state.work.parts is parts
        assert words in panel.status.content and "\n" not in panel.status.content
        assert (panel.stand_margin.value, panel.max_sag.value) == (1.0, 1.5)
    studio.project.autosave.now()
    assert studio.project.undo()
    assert "Undid: sizing bounds" in studio.project.panel.status.content
    assert studio.project.redo()
    assert studio.state.work.parts.stand_margin == 1.0

    panel.margin.value = 0.2
    sizing = wait_for_signal(session.sized, lambda: session.size_servos())
    assert not isinstance(sizing, str), sizing
    assert (sizing.stiffness["stand_margin"], sizing.stiffness["max_sag_deg"]) == (1.0, 1.5)
    assert "stand margin 1, sag ≤ 1.5°" in panel.sizing.content
    pairs = studio_sizing_pairs(studio, 0.2, stand_margin=1.0, max_sag_deg=1.5)
    sized = studio.state.work.parts
    assert [(j.servo or None, j.kp) for j in sized.joints] == pairs
    assert (sized.stand_margin, sized.max_sag_deg) == (1.0, 1.5)

    path = tmp_path / "bounds.bstudio"
    assert studio.project.save_as(str(path))
    panel.stand_margin.value = 0.25
    assert studio.project.open(str(path))
    assert (studio.state.work.parts.stand_margin, studio.state.work.parts.max_sag_deg) == (1.0, 1.5)
    assert (panel.stand_margin.value, panel.max_sag.value) == (1.0, 1.5)
    knee = robot.joint_names.index("left_knee")
    assert sized.joints[knee].servo == "mx64"
    assert studio.project.open(str(_older_with_an_m6_knee(path, tmp_path, knee)))
    opened = studio.state.work.parts
    assert (opened.stand_margin, opened.max_sag_deg) == (STAND_MARGIN, MAX_SAG_DEG)
    assert [j.servo for j in opened.joints] == [j.servo for j in sized.joints]
    assert (panel.stand_margin.value, panel.max_sag.value) == (STAND_MARGIN, MAX_SAG_DEG)

    sizing = wait_for_signal(session.sized, lambda: session.size_servos())
    assert not isinstance(sizing, str), sizing
    parts = studio.state.work.parts
    assert (parts.joints[knee].servo, parts.joints[knee].friction_model) == ("mx64", "m6")
    assert {j.friction_model for i, j in enumerate(parts.joints) if i != knee} == {"m1"}
    m6 = json.loads((BAM_PARAMS_DIR / "mx64" / "m6.json").read_text())
    firmware, kp = catalogue()["mx64"].firmware, parts.joints[knee].kp
    stiffness = m6["kt"] * firmware.vin_V * firmware.error_gain * kp / m6["R"]
    k = studio.state.work.coefficients.params.k_deg_per_Nm[knee]
    assert k == pytest.approx(math.degrees(1.0 / stiffness), rel=1e-12)
    assert "left_knee: **mx64**, peak margin" in panel.sizing.content
    assert f", kp {kp:g} on m6 (sag" in panel.sizing.content
