"""GaitResult: one solve of the gait NLP, numbers only (numpy), so it pickles across processes.

Node arrays have one row per node of the three modes, virtual knots included (a virtual knot
repeats the time and configuration of the node before it, with the post-impact velocity).
Planar layout (see planar_model): q = [x, z, pitch, planar joints], v and a alike.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from app.core.collocation.settings import GaitSettings

BOUND_TOLERANCE = 1e-6
"""Excess below this counts as holding (IPOPT's constraint tolerance)."""


@dataclasses.dataclass(frozen=True)
class BoundCheck:
    """Largest excess of each bound on the fine grid (0 when it holds)."""

    samples: int
    """Number of grid samples checked."""
    per_interval: int
    """Samples per collocation interval."""
    floor_penetration_m: float
    """Deepest a swing foot's heel or toe goes below the floor [m]."""
    swing_height_excess_m: float
    """Highest a swing foot's sole point goes above swing_height_m [m]."""
    joint_speed_excess_radps: float
    """Largest |q̇| − qd_max of a planar joint [rad/s]."""
    joint_range_excess_rad: float
    """Largest excursion of a planar joint beyond its URDF range [rad]."""
    torque_excess_Nm: float
    """Largest |τ| − tau_max_Nm [N·m] (τ is linear between knots: 0 up to round-off)."""

    @property
    def holds(self) -> bool:
        """Whether every bound holds on the grid to BOUND_TOLERANCE."""
        return (
            max(
                self.floor_penetration_m,
                self.swing_height_excess_m,
                self.joint_speed_excess_radps,
                self.joint_range_excess_rad,
                self.torque_excess_Nm,
            )
            <= BOUND_TOLERANCE
        )


@dataclasses.dataclass(frozen=True)
class GaitResult:
    """A planned gait, or the last iterate of a solve that did not converge (converged=False)."""

    status: str
    """"solved", or what went wrong in plain words."""
    converged: bool
    ipopt_status: str
    """IPOPT's own return status ("Solve_Succeeded", "Infeasible_Problem_Detected", …), or
    "not run" when the settings were refused before solving."""
    iterations: int
    solve_s: float
    """Wall-clock time of the IPOPT call [s] (the NLP was built before)."""
    objective: float
    constraint_violation: float
    """Largest violation of any constraint or bound at the returned point."""
    settings: GaitSettings
    joint_names: tuple[str, ...]
    """Planar joints (hip pitch, knee, ankle of each leg), the columns of u."""

    t: np.ndarray
    """Node times [s], shape (N,)."""
    mode: np.ndarray
    """Mode of each node (0: LSP part, 1: RSP, 2: LSP part), shape (N,) int."""
    virtual: np.ndarray
    """True at the virtual knots (first node of mode1 and mode2), shape (N,)."""
    q: np.ndarray
    """Planar configurations, shape (N, nq): x [m], z [m], pitch [rad], joints [rad]."""
    v: np.ndarray
    """Planar velocities, shape (N, nv) [m/s, rad/s]."""
    a: np.ndarray
    """Planar accelerations, shape (N, nv) [m/s², rad/s²]."""
    u: np.ndarray
    """Joint torques [N·m], shape (N, nu)."""
    stance_force: np.ndarray
    """Stance-foot force λ = (f_x, f_z heel, f_z toe) [N], shape (N, 3)."""
    contact_forces_N: np.ndarray
    """World forces (f_x, f_z) [N] at left heel, left toe, right heel, right toe, (N, 4, 2)."""
    mid_force: np.ndarray
    """DIRCON force at the collocation point of interval k → k+1 [N], shape (N−1, 3); NaN rows
    between modes (no interval there)."""
    velocity_correction: np.ndarray
    """γ of interval k → k+1, shape (N−1, 3), NaN between modes."""
    impulses: np.ndarray
    """Touch-down impulses (f_x, f_z heel, f_z toe) [N·s] of the right then the left foot, (2, 3)."""
    durations_s: np.ndarray
    """Durations of mode0, mode1, mode2 [s]."""
    footholds_m: np.ndarray
    """Sole-centre x of the stance foot in mode0, mode1, mode2 (x0, x1, x2) [m]."""
    slack0: float
    """Foothold slack: x1 = (0.5 + slack0)(x0 + x2) (eq. 5); for the baseline the value its
    footholds imply."""
    step_lengths_m: np.ndarray
    """(LSP, RSP) step lengths [m]: x1 − x0 (right foot lands ahead of the left during the LSP)
    and x2 − x1 (left lands ahead of the right during the RSP)."""
    max_abs_tau_Nm: float
    energy_J: float
    """∫ Σ max(τ·q̇, 0) dt over the gait: positive mechanical work of the joints [J]."""
    sr: float
    """Specific resistance E / (M g d) (eq. 9)."""
    exchange_residual: float
    """Largest |joint state of one leg at the end of mode0 − the other leg's at the end of
    mode1| (eq. 6) [rad, rad/s]."""
    periodicity_residual: float
    """Largest |final − initial state| with x shifted by the advance [m, rad, m/s, rad/s]."""

    z: np.ndarray
    """The NLP's decision vector, for warm starts."""
    lam_g: np.ndarray
    """Constraint multipliers at the returned point."""
    lam_x: np.ndarray
    """Bound multipliers at the returned point."""
    structure: tuple[int, bool]
    """(knots, baseline) of the NLP that produced it."""
    impact_loss_J: float = float("nan")
    """Kinetic energy lost in the two touch-down impacts, Σ ½ Δvᵀ M Δv [J]."""
    work_incl_impacts_J: float = float("nan")
    """energy_J + impact_loss_J: the planned mechanical work of the gait, impacts included [J].
    Planned work, not the paper's measured motor energy (Table 4), which adds losses."""
    sr_incl_impacts: float = float("nan")
    """work_incl_impacts_J / (M g d)."""
    bound_check: BoundCheck | None = None
    """The bounds checked on a fine grid between the knots (None when refused)."""
    blame: str = ""
    """For a solve without a gait: the constraint groups violated at its last iterate, worst
    first, with their violations and the sliders or limits that set them
    (app.core.collocation.blame); "" otherwise."""
    warm_iterations_before_cold: int = 0
    """Iterations of a warm start that did not converge within its budget, after which the
    solve restarted cold from the built-in guess (counted in `iterations` too); 0 when the
    solve did not restart."""

    @property
    def restarted_cold(self) -> bool:
        """Whether a stalled warm start was abandoned for a cold start."""
        return self.warm_iterations_before_cold > 0

    @property
    def has_gait(self) -> bool:
        """Whether there are node values at all (False when the settings were refused)."""
        return len(self.t) > 0

    @property
    def duration_s(self) -> float:
        return float(self.durations_s.sum()) if len(self.durations_s) else 0.0

    @classmethod
    def refused(cls, settings: GaitSettings, status: str) -> GaitResult:
        """A result with no gait: the settings were refused before any solve."""
        empty = np.zeros(0)
        nan = float("nan")
        return cls(
            status=status, converged=False, ipopt_status="not run", iterations=0, solve_s=0.0,
            objective=nan, constraint_violation=nan, settings=settings, joint_names=(),
            t=empty, mode=np.zeros(0, dtype=int), virtual=np.zeros(0, dtype=bool),
            q=np.zeros((0, 0)), v=np.zeros((0, 0)), a=np.zeros((0, 0)), u=np.zeros((0, 0)),
            stance_force=np.zeros((0, 3)), contact_forces_N=np.zeros((0, 4, 2)),
            mid_force=np.zeros((0, 3)), velocity_correction=np.zeros((0, 3)),
            impulses=np.zeros((0, 3)), durations_s=empty, footholds_m=empty, slack0=nan,
            step_lengths_m=empty, max_abs_tau_Nm=nan, energy_J=nan, sr=nan,
            exchange_residual=nan, periodicity_residual=nan, z=empty, lam_g=empty,
            lam_x=empty, structure=settings.structure,
        )  # fmt: skip

    def summary(self) -> dict[str, object]:
        """The headline numbers as plain JSON-able values."""
        return {
            "status": self.status,
            "converged": self.converged,
            "ipopt_status": self.ipopt_status,
            "iterations": self.iterations,
            "solve_s": self.solve_s,
            "objective": self.objective,
            "constraint_violation": self.constraint_violation,
            "max_abs_tau_Nm": self.max_abs_tau_Nm,
            "step_lengths_m": [float(x) for x in self.step_lengths_m],
            "footholds_m": [float(x) for x in self.footholds_m],
            "slack0": self.slack0,
            "durations_s": [float(x) for x in self.durations_s],
            "energy_J": self.energy_J,
            "sr": self.sr,
            "exchange_residual": self.exchange_residual,
            "periodicity_residual": self.periodicity_residual,
            "impact_loss_J": self.impact_loss_J,
            "work_incl_impacts_J": self.work_incl_impacts_J,
            "sr_incl_impacts": self.sr_incl_impacts,
            "warm_iterations_before_cold": self.warm_iterations_before_cold,
            "bound_check": None
            if self.bound_check is None
            else {**dataclasses.asdict(self.bound_check), "holds": self.bound_check.holds},
            "baseline": self.settings.baseline,
            "knots": self.settings.knots,
        }
