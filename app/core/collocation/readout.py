"""Reading a solved NLP back into a GaitResult: node arrays, footholds, residuals, SR."""

from __future__ import annotations

import dataclasses

import numpy as np

from app.core.collocation.bound_check import check_bounds, impact_losses
from app.core.collocation.nlp import SolveOutcome
from app.core.collocation.planar_model import PlanarModel
from app.core.collocation.result import GaitResult
from app.core.collocation.sampling import positive_work
from app.core.collocation.settings import GaitSettings
from app.core.collocation.transcription import STANCE, GaitLayout, point_forces


def _status(out: SolveOutcome) -> str:
    if out.raw_status == "Maximum_Iterations_Exceeded":
        return f"{out.words} ({out.iterations} iterations); the last iterate is not a gait"
    if not out.converged:
        return f"{out.words}; the last iterate is shown, not a gait"
    return out.words


def read_result(
    out: SolveOutcome,
    s: GaitSettings,
    model: PlanarModel,
    layout: GaitLayout,
    blocks: dict[str, list[slice]],
) -> GaitResult:
    """The GaitResult of a solve (converged or not): `blocks` are the NLP's variable slices."""
    x = out.x

    def stack(name: str) -> np.ndarray:
        return np.array([x[sl] for sl in blocks[name]])

    N = layout.n_nodes
    q, v, a, u, lam = (stack(n) for n in ("q", "v", "a", "u", "lam"))
    if s.baseline:
        durations = x[blocks["T"][0]].copy()
        x1 = float(x[blocks["x1"][0]][0])
        slack = x1 / s.step_length_m - 0.5 if s.step_length_m > 0 else float("nan")
    else:
        durations = np.array(layout.symmetric_durations(s.H_s), dtype=float)
        slack = float(x[blocks["slack"][0]][0])
        x1 = (0.5 + slack) * s.step_length_m
    footholds = np.array([0.0, x1, s.step_length_m])
    mode = np.searchsorted(np.cumsum(layout.sizes), np.arange(N), side="right")  # mode_of
    virtual = np.zeros(N, dtype=bool)
    virtual[[layout.first(1), layout.first(2)]] = True
    mid = np.full((N - 1, 3), np.nan)
    gamma = np.full((N - 1, 3), np.nan)
    pairs = [k for j in range(3) for k in list(layout.nodes(j))[:-1]]
    mid[pairs] = stack("lam_mid")
    gamma[pairs] = stack("gamma")
    forces = np.zeros((N, 4, 2))
    for j, side in enumerate(STANCE):
        forces[mode == j] = point_forces(lam[mode == j], side)
    left, right = model.leg_joints["left"], model.leg_joints["right"]
    e0, e1 = layout.last(0), layout.last(1)
    exchange = max(
        np.abs(state[e0, one] - state[e1, two]).max()
        for state in (q, v)
        for one, two in ((left, right), (right, left))
    )
    shift = np.zeros(model.nq)
    shift[0] = s.step_length_m
    periodic = max(np.abs(q[-1] - q[0] - shift).max(), np.abs(v[-1] - v[0]).max())
    result = GaitResult(
        status=_status(out), converged=out.converged, ipopt_status=out.raw_status,
        iterations=out.iterations, solve_s=out.seconds, objective=out.objective,
        constraint_violation=out.violation, settings=s, joint_names=model.joint_names,
        t=layout.node_times(durations), mode=mode, virtual=virtual, q=q, v=v, a=a, u=u,
        stance_force=lam, contact_forces_N=forces, mid_force=mid, velocity_correction=gamma,
        impulses=stack("impulse"), durations_s=durations, footholds_m=footholds,
        slack0=float(slack), step_lengths_m=np.diff(footholds),
        max_abs_tau_Nm=float(np.abs(u).max()), energy_J=float("nan"), sr=float("nan"),
        exchange_residual=float(exchange), periodicity_residual=float(periodic),
        z=out.x, lam_g=out.lam_g, lam_x=out.lam_x, structure=s.structure,
    )  # fmt: skip
    energy = positive_work(result)
    weight_distance = model.mass_kg * model.gravity * s.step_length_m
    sr = energy / weight_distance if weight_distance > 0 else float("nan")
    impacts = float(impact_losses(model, result).sum())
    work = energy + impacts
    return dataclasses.replace(
        result,
        energy_J=energy,
        sr=sr,
        impact_loss_J=impacts,
        work_incl_impacts_J=work,
        sr_incl_impacts=work / weight_distance if weight_distance > 0 else float("nan"),
        bound_check=check_bounds(model, result),
    )
