"""The readout of a solved gait, vectorised (issue 28), gives the numbers of the plain loop.

The bound check and the positive work now sample the three modes in one call and evaluate the
contact points with one mapped casadi function kept by the model. The reference here is the
loop they replaced, written out plainly: each interval's times from np.linspace, each mode
sampled on its own with sample_gait, the contact points evaluated one configuration at a time
with the unmapped function. On the paper's case and servo_biped, the same bounds and the same
work to 1e-12 (relative), and the readout's node modes equal the layout's.
"""

from __future__ import annotations

import numpy as np
import pytest

from app.core.collocation.bound_check import check_bounds
from app.core.collocation.defaults import robot_gait_defaults
from app.core.collocation.gait_problem import GaitProblem
from app.core.collocation.planar_model import BASE_DOF, PlanarModel, evaluate
from app.core.collocation.sampling import interval_grid, positive_work, sample_gait
from app.core.collocation.settings import GaitSettings
from app.core.collocation.transcription import STANCE, GaitLayout, other, swing_z_rows
from app.core.robot.loading import load_robot

TOLERANCE = 1e-12


@pytest.fixture(scope="module", params=["dircon_biped", "servo_biped"])
def solved(request):
    planar = PlanarModel(load_robot(request.param))
    if request.param == "dircon_biped":
        settings = GaitSettings()
    else:
        settings = robot_gait_defaults(planar).settings
    problem = GaitProblem(planar, settings.knots, settings.baseline)
    result = problem.solve(settings, cold=True)
    assert result.converged, result.status
    return problem, result


def _mode_times(result, mode: int, per_interval: int, inner: bool) -> np.ndarray:
    nodes = list(GaitLayout.from_knots(result.structure[0]).nodes(mode))
    parts = []
    for k in nodes[:-1]:
        grid = np.linspace(result.t[k], result.t[k + 1], per_interval + 1)
        parts.append(grid[1:-1] if inner else grid[:-1])
    last = result.t[nodes] if inner else result.t[nodes[-1] : nodes[-1] + 1]
    return np.concatenate([*parts, last])


def _reference_bounds(model: PlanarModel, result) -> dict[str, float]:
    s = result.settings
    worst = dict.fromkeys(("floor", "height", "speed", "range", "torque"), 0.0)
    count = 0
    for mode in range(3):
        t = _mode_times(result, mode, s.check_per_interval, inner=True)
        samples = sample_gait(result, t, np.full(len(t), mode))
        rows = swing_z_rows(other(STANCE[mode]))
        for qk in samples.q:
            z = rows @ evaluate(model.contact_positions, qk)
            worst["floor"] = max(worst["floor"], float(-z.min()))
            worst["height"] = max(worst["height"], float(z.max() - s.swing_height_m))
        joints = samples.q[:, BASE_DOF:]
        worst["speed"] = max(
            worst["speed"], float(np.abs(samples.v[:, BASE_DOF:]).max() - s.qd_max)
        )
        worst["range"] = max(
            worst["range"],
            float(np.max(joints - model.upper)),
            float(np.max(model.lower - joints)),
        )
        worst["torque"] = max(worst["torque"], float(np.abs(samples.u).max() - s.tau_max_Nm))
        count += len(t)
    return {"samples": count, **worst}


def _reference_work(result, per_interval: int = 24) -> float:
    total = 0.0
    for mode in range(3):
        t = _mode_times(result, mode, per_interval, inner=False)
        samples = sample_gait(result, t, np.full(len(t), mode))
        power = np.maximum(samples.u * samples.v[:, BASE_DOF:], 0.0).sum(axis=1)
        total += float(np.sum(0.5 * (power[1:] + power[:-1]) * np.diff(t)))
    return total


def _close(a: float, b: float) -> bool:
    return abs(a - b) <= TOLERANCE * max(1.0, abs(b))


def test_bound_check_equals_the_per_sample_loop(solved):
    problem, result = solved
    check = check_bounds(problem.model, result)
    reference = _reference_bounds(problem.model, result)
    assert check.samples == reference["samples"]
    assert _close(check.floor_penetration_m, reference["floor"])
    assert _close(check.swing_height_excess_m, reference["height"])
    assert _close(check.joint_speed_excess_radps, reference["speed"])
    assert _close(check.joint_range_excess_rad, reference["range"])
    assert _close(check.torque_excess_Nm, reference["torque"])
    assert check == result.bound_check  # what the solve read out


def test_positive_work_equals_the_per_mode_loop(solved):
    _, result = solved
    assert _close(positive_work(result), _reference_work(result))
    assert _close(result.energy_J, _reference_work(result))


def test_readout_modes_are_the_layouts(solved):
    _, result = solved
    layout = GaitLayout.from_knots(result.structure[0])
    assert result.mode.tolist() == [layout.mode_of(k) for k in range(layout.n_nodes)]


def test_the_mapped_points_are_built_once_per_sample_count(solved):
    problem, result = solved
    check_bounds(problem.model, result)
    kept = dict(problem.model._mapped_points)
    check_bounds(problem.model, result)
    assert problem.model._mapped_points == kept
    assert all(problem.model._mapped_points[n] is f for n, f in kept.items())


@pytest.mark.parametrize("per_interval", [1, 2, 8, 24])
def test_interval_grid_is_linspace_bit_for_bit(per_interval):
    rng = np.random.default_rng(per_interval)
    t = np.concatenate([[0.0], np.cumsum(rng.uniform(1e-3, 0.1, 12))])
    nodes = range(2, 11)
    grid = interval_grid(t, nodes, per_interval, inner=False)
    inner = interval_grid(t, nodes, per_interval, inner=True)
    for row, k in enumerate(list(nodes)[:-1]):
        expected = np.linspace(t[k], t[k + 1], per_interval + 1)
        assert np.array_equal(grid[row], expected)
        assert np.array_equal(inner[row], expected[1:-1])
