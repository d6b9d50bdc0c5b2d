"""The Sweep panel with a servo parameter and the simulation, on a real studio whose sweep workers
were prepared when the robot loaded: the metrics equal the same points evaluated one by one in
this process through app.core (not through the panel), the fallen points are drawn apart, and a
loaded point brings its servo settings to the Compensation panel."""

from __future__ import annotations

import numpy as np
import pytest

from app.config import StudioConfig
from app.core.sweeps.servo_metrics import SERVO_PARAMETERS
from app.studio import Studio
from tests.studio.conftest import (
    GUARD_S,
    assert_points_match_core,
    free_port,
    load_point,
    run_sweep,
    set_sweep,
)

COMPLIANCE = (0.0, 3.0)
"""The swept servo compliance [°/(N·m)]: rigid to twice the paper's identifiable servos."""
SAME = {
    "robot": "dircon_biped",
    "sampling": "latin",
    "samples": 2,
    "seed": 0,
    "gait": {"knots": 14},
    "simulate": True,
    "walk_steps": 1,
    "pareto": {"sr": "min", "max_torso_error_deg": "min"},
    "parameter": [
        {"kind": "servo", "name": "compliance_deg_per_Nm", "min": 0.0, "max": 3.0},
    ],
}
"""The sweep the panel is set to, written out for app.core (the panel's defaults: seed 0)."""
METRICS = (
    "sr",
    "max_torque_Nm",
    "max_joint_speed_radps",
    "fell",
    "fall_time_s",
    "max_torso_error_deg",
    "max_tracking_error_deg",
    "rms_joint_error_deg",
)


@pytest.fixture
def prepared_studio(tmp_path):
    data = tmp_path / "data"
    config = StudioConfig(
        robot="dircon_biped",
        port=free_port(),
        data_dir=data,
        allow=(data.parent,),
        prepare_sweep=True,
    )
    studio = Studio(config)
    yield studio
    studio.stop()


def test_a_servo_sweep_with_simulation_matches_core_and_loads_its_servos(prepared_studio):
    studio = prepared_studio
    session, panel = studio.sweep, studio.sweep.panel
    # the workers were prepared in the background when the robot loaded: each built the NLP
    workers = session.workers
    assert workers.prepared.wait(GUARD_S)
    assert len(workers.prepared_s) == 2 and all(s > 0 for s in workers.prepared_s.values())
    assert "2 workers ready" in panel.status.content

    set_sweep(panel, ("servo:compliance_deg_per_Nm", *COMPLIANCE), samples=2, workers=2)
    panel.walk_steps.value = 1
    panel.metric_x.value, panel.metric_y.value = "sr", "max_torso_error_deg"
    assert "s more per point (1 step;" in panel.cost_line.content

    # bad input: a servo parameter without the simulation is refused, saying what to switch on
    panel.simulate.value = False
    session.run(None)
    assert "set simulate = true" in panel.status.content and session.outcome is None

    panel.simulate.value = True
    outcome = run_sweep(studio)
    assert not outcome.error and len(outcome.results) == 2
    by_panel = sorted(outcome.results, key=lambda r: r.index)
    # prepared workers: no point paid an NLP build or anchor solve
    assert all(r.build_s == 0.0 for r in by_panel)

    # the same points, sampled and evaluated one by one here through app.core
    for point in assert_points_match_core(by_panel, SAME, METRICS):
        assert COMPLIANCE[0] <= point.values[0] <= COMPLIANCE[1]
    assert any(np.isfinite(r.fell) for r in by_panel), [r.sim_status for r in by_panel]

    # the plot: standing and fallen points in their own series, the progress line counts them
    fell = [r for r in by_panel if r.fell == 1.0]
    standing = [r for r in by_panel if r.solved and r.fell == 0.0]
    assert panel.plot is not None
    _x, up, down, _front, _failed = panel.plot.data
    assert np.count_nonzero(np.isfinite(down)) == len(fell)
    assert np.count_nonzero(np.isfinite(up)) == len(standing)
    solved = len(fell) + len(standing)
    assert f"{solved} solved ({len(fell)} fell in simulation)" in panel.status.content

    # Load point: the design, its walk, and the servos it was simulated with
    best = next(r for r in by_panel if r.solved)
    assert load_point(studio, best.index) == best.index
    robot = studio.state.robot
    coefficients = studio.state.work.coefficients
    assert robot is not None and coefficients is not None
    knees = [i for i, name in enumerate(robot.joint_names) if "knee" in name]
    (compliance,) = best.values
    servo, params = coefficients.servo, coefficients.params
    assert servo.joint_names == robot.joint_names
    assert np.allclose(servo.compliance_deg_per_Nm[knees], compliance)
    assert np.allclose(servo.backlash_deg[knees], SERVO_PARAMETERS["dead_band_deg"].default)
    # compensation on (the default): eq 7's k is the servos' own compliance
    assert params.enabled[knees].all() and np.allclose(params.k_deg_per_Nm[knees], compliance)
    assert "servos" in studio.state.motion.summary
