"""Gait plans between the knots: spline evaluation, positive work, and the Trajectory.

As in the paper (section 3.2) and DIRCON, within each interval of a mode
- q(t) is the cubic Hermite spline through (q_k, v_k) and (q_k+1, v_k+1),
- v(t) is the cubic Hermite spline through (v_k, a_k) and (v_k+1, a_k+1), a(t) its derivative,
- u(t) is linear between u_k and u_k+1,
- the stance force is linear from λ_k to the collocation force λ̄ at mid-interval and on to
  λ_k+1, so the equations of motion hold exactly at knots and collocation points and every
  sample is a convex combination of forces inside the friction cone.
dq/dt and v(t) agree at both knots and at the collocation point (that is the collocation
constraint, up to the velocity correction γ); elsewhere they differ by O(h³).

At a touch-down time the sample belongs to the new mode (post-impact velocity, new stance foot).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from app.core.budgets import check_dt, check_samples
from app.core.collocation.planar_model import PlanarModel
from app.core.collocation.result import GaitResult
from app.core.collocation.transcription import STANCE, GaitLayout, point_forces
from app.core.errors import StudioError
from app.core.motions.trajectory import Trajectory
from app.core.robot.model import RobotModel

TIME_TOLERANCE_S = 1e-9


@dataclasses.dataclass(frozen=True)
class GaitSamples:
    """The planned gait at arbitrary times (planar layout)."""

    t: np.ndarray
    """Times [s], shape (T,)."""
    mode: np.ndarray
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    u: np.ndarray
    """Joint torques [N·m], (T, nu)."""
    stance_force: np.ndarray
    """(f_x, f_z heel, f_z toe) of the stance foot [N], (T, 3)."""
    contact_forces_N: np.ndarray
    """(f_x, f_z) at left heel, left toe, right heel, right toe [N], (T, 4, 2)."""
    contacts: np.ndarray
    """(left, right) in contact, (T, 2) bool."""


def _hermite(
    p0: np.ndarray, m0: np.ndarray, p1: np.ndarray, m1: np.ndarray, h: Any, s: Any
) -> tuple[np.ndarray, np.ndarray]:
    """Value and time derivative of the cubic Hermite spline at s ∈ [0, 1] of a step h (all
    arguments broadcast: one row per sample, h and s as columns)."""
    s2, s3 = s * s, s * s * s
    value = (
        (2 * s3 - 3 * s2 + 1) * p0
        + (s3 - 2 * s2 + s) * h * m0
        + (3 * s2 - 2 * s3) * p1
        + (s3 - s2) * h * m1
    )
    slope = (
        (6 * s2 - 6 * s) * p0
        + (3 * s2 - 4 * s + 1) * h * m0
        + (6 * s - 6 * s2) * p1
        + (3 * s2 - 2 * s) * h * m1
    ) / h
    return value, slope


def _spline_points(
    result: GaitResult, times: np.ndarray, chosen: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The interval k of each sample (from node k to k + 1, within its mode), its step h and
    its place s ∈ [0, 1] in it (h and s as columns)."""
    layout = GaitLayout.from_knots(result.structure[0])
    k = np.zeros(len(times), dtype=int)
    for mode in range(3):
        rows = chosen == mode
        nodes = np.array(layout.nodes(mode))
        after = np.searchsorted(result.t[nodes], times[rows], side="right") - 1
        k[rows] = nodes[0] + np.clip(after, 0, len(nodes) - 2)
    h = (result.t[k + 1] - result.t[k])[:, None]
    s = np.clip((times[:, None] - result.t[k][:, None]) / h, 0.0, 1.0)
    return k, h, s


def sample_states(
    result: GaitResult, times: np.ndarray, modes: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(q, v, u) of sample_gait at `times` in `modes`, without the accelerations and forces
    (the bound check and the positive work of every solve need only these)."""
    times = np.asarray(times, dtype=float)
    k, h, s = _spline_points(result, times, np.asarray(modes, dtype=int).reshape(len(times)))
    q = _hermite(result.q[k], result.v[k], result.q[k + 1], result.v[k + 1], h, s)[0]
    v = _hermite(result.v[k], result.a[k], result.v[k + 1], result.a[k + 1], h, s)[0]
    return q, v, (1 - s) * result.u[k] + s * result.u[k + 1]


def sample_gait(
    result: GaitResult, times: np.ndarray, modes: np.ndarray | None = None
) -> GaitSamples:
    """The gait at `times` [s] within [0, duration]; `modes` picks the mode of each time
    (default: from the time, the new mode at a touch-down)."""
    if not result.has_gait:
        raise StudioError(f"no gait to sample: {result.status}")
    times = np.asarray(times, dtype=float)
    bounds = np.cumsum(result.durations_s)
    n = len(times)
    out: dict[str, np.ndarray] = {}
    if modes is None:
        chosen = np.searchsorted(bounds[:2] - TIME_TOLERANCE_S, times, side="right")
    else:
        chosen = np.asarray(modes, dtype=int).reshape(n)
    k, h, s = _spline_points(result, times, chosen)
    out["q"] = _hermite(result.q[k], result.v[k], result.q[k + 1], result.v[k + 1], h, s)[0]
    out["v"], out["a"] = _hermite(result.v[k], result.a[k], result.v[k + 1], result.a[k + 1], h, s)
    out["u"] = (1 - s) * result.u[k] + s * result.u[k + 1]
    mid = result.mid_force[k]
    out["lam"] = np.where(
        s <= 0.5,
        (1 - 2 * s) * result.stance_force[k] + 2 * s * mid,
        (2 - 2 * s) * mid + (2 * s - 1) * result.stance_force[k + 1],
    )
    forces = np.zeros((n, 4, 2))
    contacts = np.zeros((n, 2), dtype=bool)
    for mode, side in enumerate(STANCE):
        rows = chosen == mode
        forces[rows] = point_forces(out["lam"][rows], side)
        contacts[rows, 0 if side == "left" else 1] = True
    return GaitSamples(
        t=times, mode=chosen, q=out["q"], v=out["v"], a=out["a"], u=out["u"],
        stance_force=out["lam"], contact_forces_N=forces, contacts=contacts,
    )  # fmt: skip


def interval_grid(t: np.ndarray, nodes: range, per_interval: int, *, inner: bool) -> np.ndarray:
    """Times splitting each interval of `nodes` into `per_interval` steps, as np.linspace does
    per interval (bit for bit), without a Python loop: (intervals, per_interval + 1), each row
    from the interval's start to its end; `inner` drops both ends (the knots)."""
    start, stop = t[nodes[0] : nodes[-1]], t[nodes[0] + 1 : nodes[-1] + 1]
    step = (stop - start) / per_interval
    grid = np.arange(per_interval + 1)[None, :] * step[:, None] + start[:, None]
    grid[:, -1] = stop
    return grid[:, 1:-1] if inner else grid


def positive_work(result: GaitResult, per_interval: int = 24) -> float:
    """E = ∫ Σ_joints max(τ·q̇, 0) dt [J], by the trapezoid rule on each mode's splines (the
    three modes sampled in one call, summed per mode)."""
    layout = GaitLayout.from_knots(result.structure[0])
    times, modes = [], []
    for mode in range(3):
        nodes = layout.nodes(mode)
        grid = interval_grid(result.t, nodes, per_interval, inner=False)[:, :-1]
        t = np.concatenate([grid.ravel(), result.t[nodes[-1] : nodes[-1] + 1]])
        times.append(t)
        modes.append(np.full(len(t), mode))
    _, v, u = sample_states(result, np.concatenate(times), np.concatenate(modes))
    power = np.maximum(u * v[:, 3:], 0.0).sum(axis=1)
    total, start = 0.0, 0
    for t in times:
        p, start = power[start : start + len(t)], start + len(t)
        if len(t) >= 2:
            total += float(np.sum(0.5 * (p[1:] + p[:-1]) * np.diff(t)))
    return total


def to_trajectory(robot: RobotModel, result: GaitResult, dt: float = 0.01) -> Trajectory:
    """The gait sampled every dt [s] (the paper's 100 Hz) on the full robot: roll/yaw joints and
    the base's y, roll and yaw at zero. q is the Hermite spline of the planar q; v and a are the
    Hermite spline of v and its derivative (not finite differences), mapped to pinocchio's
    base-frame twist; contacts follow the modes (left, right, left)."""
    if not result.has_gait:
        raise StudioError(f"no gait to sample: {result.status}")
    check_dt(dt)
    check_samples(result.duration_s / dt + 1, robot.model.nq, f"the gait at dt {dt:g} s")
    planar = PlanarModel(robot)
    if planar.joint_names != result.joint_names:
        raise StudioError(
            f"the gait was planned for joints {', '.join(result.joint_names)}; "
            f"{robot.name} has planar joints {', '.join(planar.joint_names)}"
        )
    times = np.arange(int(np.floor(result.duration_s / dt + 1e-9)) + 1) * dt
    samples = sample_gait(result, times)
    q = planar.to_full_q(samples.q)
    v = np.array([planar.to_full_v(qk, vk) for qk, vk in zip(samples.q, samples.v, strict=True)])
    a = np.array(
        [
            planar.to_full_a(qk, vk, ak)
            for qk, vk, ak in zip(samples.q, samples.v, samples.a, strict=True)
        ]
    )
    name = "baseline DIRCON gait" if result.settings.baseline else "symmetric gait"
    return Trajectory(
        name=name, joint_names=robot.joint_names, t=times, q=q, v=v, a=a, contacts=samples.contacts
    )
