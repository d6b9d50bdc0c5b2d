"""A sweep point over servo parts, loaded into a real studio, keeps its parts: its servo and kp
on the legs in the Servos folder's state (the ideal servo elsewhere), eq 7's k = 1/K of that
part (the motor law's closed form), and a point simulated on the virtual servos puts every
joint back on the ideal servo. The point's gait is solved in this process (the sweep's worker
does the same in a Dask process; tests/test_sweep_parts_simulation.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from app.core.servo.catalogue import load_catalogue
from app.core.servo.choice import JointServo
from app.core.servo.presets import uniform_preset
from app.core.sweeps.evaluate import ProblemCache, solve_point
from app.core.sweeps.sampling import sweep_points
from app.core.sweeps.spec import SweepSpec
from app.studio.sweep_loading import PointLoader

KP = 40.0


class InProcess:
    """What the loader asks of the sweep engine: a point's gait, solved here."""

    def __init__(self) -> None:
        self.cache = ProblemCache()

    def solve(self, point):
        return solve_point(point, self.cache)


def point_of(part: dict | None):
    data = {
        "sampling": "grid",
        "gait": {"knots": 14},
        "simulate": True,
        "walk_steps": 1,
        "parameter": [
            {"kind": "servo", "name": "dead_band_deg", "min": 0.2, "max": 0.2, "levels": 1}
        ],
    }
    if part is not None:
        data["part"] = part
    (point,) = sweep_points(SweepSpec.from_mapping(data))
    return point


def test_a_loaded_point_keeps_its_parts(studio, tmp_path):
    assert studio.robots.load("dircon_biped")
    loader = PointLoader(
        studio.web.server,
        studio.state,
        tmp_path / "variants",
        studio.servo_rooms.compensation.set_servos,
    )
    engine = InProcess()
    loader.load(engine, point_of({"servo": "mx106", "kp": KP}))
    robot = studio.state.robot
    legs = uniform_preset(robot).enabled
    parts = studio.state.work.parts
    for name, on in zip(robot.joint_names, legs, strict=True):
        expected = JointServo("mx106", kp=KP, dead_band_deg=0.2) if on else JointServo()
        assert parts.joint(name) == expected, name
    record = load_catalogue()["mx106"]
    motor, firmware = record.fit("m1").motor, record.firmware
    stiffness = motor.kt_Nm_per_A * firmware.vin_V * firmware.error_gain * KP / motor.R_ohm
    k = studio.state.work.coefficients.params.k_deg_per_Nm
    np.testing.assert_allclose(k[legs], math.degrees(1.0 / stiffness), rtol=1e-12)
    assert "mx106 at kp 40 on the legs" in studio.state.motion.summary
    # the Servos folder shows the part of its selected leg joint
    first_leg = robot.joint_names[int(np.flatnonzero(legs)[0])]
    studio.servo_rooms.servos.panel.joint.value = first_leg
    assert studio.servo_rooms.servos.panel.servo.value.startswith("mx106 ")
    assert studio.servo_rooms.servos.panel.settings["kp"].value == pytest.approx(KP)

    loader.load(engine, point_of(None))  # on the virtual servos: every joint ideal again
    assert studio.state.work.parts.chosen == ()
    assert studio.servo_rooms.servos.panel.servo.value == "ideal servo"


def test_the_sweep_panel_offers_the_servo_and_its_kp(studio):
    from app.core.servo.choice import simulatable
    from app.studio.sweep_choices import SweptRobot, panel_data

    assert studio.robots.load("dircon_biped")
    session, panel = studio.sweep, studio.sweep.panel
    assert {"part:servo", "part:kp"} <= set(panel.param_a.options)
    runnable = sorted(simulatable(load_catalogue()))
    panel.param_a.value = "part:servo"  # its range: every servo the simulation can run
    assert (panel.min_a.value, panel.max_a.value) == (0, len(runnable) - 1)
    panel.min_a.value, panel.max_a.value = 1, 2
    panel.param_b.value = "part:kp"
    panel.min_b.value, panel.max_b.value = 16, 32
    # without the simulation: refused in one line naming the part parameters
    panel.simulate.value = False
    session.run(None)
    assert "part parameter servo" in panel.status.content
    assert session.outcome is None
    # an index past the list: refused, naming the servos by index
    panel.simulate.value = True
    panel.max_a.value = len(runnable)
    session.run(None)
    assert "must be indices" in panel.status.content and runnable[0] in panel.status.content
    assert session.outcome is None
    # the sweep the panel's rows make: the servos 1 … 2 as choices, kp 16 … 32
    panel.max_a.value = 2
    data = SweptRobot(robot="dircon_biped").spec_data(panel.spec_values())
    spec = SweepSpec.from_mapping(data)
    servo, kp = spec.parameters
    assert servo.choices == tuple(runnable[1:3])
    assert (kp.kind, kp.minimum, kp.maximum) == ("part", 16.0, 32.0)
    # and shown again (a project's sweep) as the same rows
    shown = panel_data(data)["parameter"][0]
    assert (shown["min"], shown["max"]) == (1.0, 2.0)


def test_the_sweep_panel_offers_the_projects_servo_files_and_the_part_axes(studio):
    from app.core.servo.choice import simulatable
    from app.core.sweeps.part_metrics import PART_METRICS
    from app.studio.sweep_choices import panel_data
    from tests.test_sweep_part_axes import user_mx106

    assert studio.robots.load("dircon_biped")
    session, panel = studio.sweep, studio.sweep.panel
    assert set(PART_METRICS) <= set(panel.metric_x.options)  # the parts' Pareto axes
    assert studio.servo_rooms.servos.add_servo_file("mine.toml", user_mx106().encode())
    keys = sorted([*simulatable(load_catalogue()), "my106"])
    assert f"{keys.index('my106')} my106" in panel.robot_line.content
    panel.param_a.value = "part:servo"  # its range: the built-in servos and the project's
    assert (panel.min_a.value, panel.max_a.value) == (0, len(keys) - 1)
    at = keys.index("my106")
    panel.min_a.value, panel.max_a.value = at - 1, at
    panel.simulate.value = True
    panel.metric_x.value, panel.metric_y.value = "servo_mass_kg", "electrical_energy_J"
    data = session.panel_sweep()
    assert [f["name"] for f in data["user_servos"]] == ["mine.toml"]  # the file it chooses from
    spec = SweepSpec.from_mapping(data)
    assert spec.parameters[0].choices == (keys[at - 1], "my106")
    assert spec.pareto == (("servo_mass_kg", "min"), ("electrical_energy_J", "min"))
    mine = [p for p in sweep_points(spec) if p.simulation.part.servo == "my106"]
    assert mine and all([r.key for r in p.simulation.part.records] == ["my106"] for p in mine)
    # the margin is better large: the panel's front maximises it
    panel.metric_y.value = "servo_margin"
    assert session.panel_sweep()["pareto"] == {"servo_mass_kg": "min", "servo_margin": "max"}
    panel.metric_y.value = "electrical_energy_J"
    # a sweep of built-in servos only carries no file
    panel.min_a.value, panel.max_a.value = 0, 1
    assert "user_servos" not in session.panel_sweep()
    # shown again (a project's sweep) as the same rows
    shown = panel_data(data, studio.state.work.parts.user_servos)["parameter"][0]
    assert (shown["min"], shown["max"]) == (at - 1.0, float(at))


def test_a_loaded_point_on_a_users_servo_brings_its_file_back(studio, tmp_path):
    from app.core.servo.user_files import UserServoFile
    from tests.test_sweep_part_axes import user_mx106

    assert studio.robots.load("dircon_biped")
    assert studio.state.work.parts is None or not studio.state.work.parts.user_servos
    file = UserServoFile("mine.toml", user_mx106())
    data = {
        "sampling": "grid",
        "gait": {"knots": 14},
        "simulate": True,
        "walk_steps": 1,
        "user_servos": [{"name": file.name, "text": file.text}],
        "parameter": [{"kind": "part", "name": "servo", "choices": ["my106"]}],
    }
    spec = SweepSpec.from_mapping(data)
    (point,) = sweep_points(spec)
    loader = PointLoader(
        studio.web.server,
        studio.state,
        tmp_path / "variants",
        studio.servo_rooms.compensation.set_servos,
    )
    loader.load(InProcess(), point, spec.user_servos)
    parts = studio.state.work.parts
    assert parts.user_servos == (file,)
    robot = studio.state.robot
    legs = uniform_preset(robot).enabled
    assert {parts.joint(n).servo for n, on in zip(robot.joint_names, legs, strict=True) if on} == {
        "my106"
    }
    assert "my106" in studio.servo_rooms.servos.records  # offered in the Servos folder again
