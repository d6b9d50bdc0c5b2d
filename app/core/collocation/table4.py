"""Our planner's symmetric vs baseline gaits beside the paper's Table 4, saying what is compared.

The paper's figures (app.core.papers.TABLE4) are its robot's: the largest joint input of the
planned gaits and the specific resistance from the *measured motor energy* of the real robot.
Ours are planned: the largest planned joint torque, and the planned mechanical work of a rigid
model — the joints' positive work plus the kinetic energy lost in the touch-down impacts —
divided by M·g·d. Absolute values are not alike; the symmetric/baseline ratios are what can be
set side by side.
"""

from __future__ import annotations

import dataclasses
import math

from app.core.collocation.result import GaitResult
from app.core.papers import TABLE4

WHAT_IS_COMPARED = (
    "ours: planned max |τ| and planned mechanical work (positive joint work + impact losses) "
    "/ (M g d) of a rigid model; paper (Table 4, section 5.3): max joint input of its planned "
    "gaits and SR from the real robot's measured motor energy — compare the ratios, not the "
    "absolute values"
)


BINDS_FRACTION = 0.999
"""A gait's torque bound binds when its largest planned |τ| reaches this fraction of it."""
LIFTED_BOUND_FACTOR = 10.0
"""The baseline is solved again with its torque bound this many times larger, to read the peak
it would plan without it."""


def bound_binds(result: GaitResult) -> bool:
    """Whether the gait's largest planned |τ| sits on its torque bound (the peak is the bound,
    not what the gait needs)."""
    bound = result.settings.tau_max_Nm
    return math.isfinite(result.max_abs_tau_Nm) and result.max_abs_tau_Nm >= BINDS_FRACTION * bound


@dataclasses.dataclass(frozen=True)
class Table4Row:
    name: str
    ours_symmetric: float
    ours_baseline: float
    paper_symmetric: float
    paper_baseline: float

    @property
    def ours_ratio(self) -> float:
        """Symmetric / baseline of our gaits."""
        return self.ours_symmetric / self.ours_baseline

    @property
    def paper_ratio(self) -> float:
        return self.paper_symmetric / self.paper_baseline


def table4_rows(symmetric: GaitResult, baseline: GaitResult) -> tuple[Table4Row, ...]:
    """Max torque [N·m] and SR (with impacts) of both gaits beside Table 4's."""
    return (
        Table4Row("max |τ| [N·m]", symmetric.max_abs_tau_Nm, baseline.max_abs_tau_Nm,
                  *TABLE4.max_abs_tau_Nm),
        Table4Row("SR", symmetric.sr_incl_impacts, baseline.sr_incl_impacts, *TABLE4.sr),
    )  # fmt: skip


def simulated_sr_row(symmetric_sr: float, baseline_sr: float) -> Table4Row:
    """The SRs from the electrical energy of both gaits' walks simulated on the ideal servo
    (`app.core.simulation.walk_sr`) beside Table 4's from measured motor energy: like for
    like, but for the motor (a stated default, not the paper's robot's)."""
    return Table4Row("SR electrical (simulated walks)", symmetric_sr, baseline_sr, *TABLE4.sr)


def table4_comparison(
    symmetric: GaitResult, baseline: GaitResult, unbounded: GaitResult | None = None
) -> dict[str, object]:
    """The comparison as JSON-able values. `unbounded`: the baseline solved again with its
    torque bound lifted (`LIFTED_BOUND_FACTOR`), when its bound binds: its own peak |τ| and
    the symmetric/baseline ratio on it."""
    lifted = None
    if unbounded is not None:
        lifted = {
            "converged": unbounded.converged,
            "torque_bound_Nm": unbounded.settings.tau_max_Nm,
            "max_abs_tau_Nm": unbounded.max_abs_tau_Nm,
            "binds": bound_binds(unbounded),
            "ratio": symmetric.max_abs_tau_Nm / unbounded.max_abs_tau_Nm,
            "sr_incl_impacts": unbounded.sr_incl_impacts,
        }
    return {
        "torque_bound_Nm": [symmetric.settings.tau_max_Nm, baseline.settings.tau_max_Nm],
        "bound_binds": [bound_binds(symmetric), bound_binds(baseline)],
        "baseline_bound_lifted": lifted,
        "what": WHAT_IS_COMPARED,
        "rows": [
            {
                "name": row.name,
                "ours": [row.ours_symmetric, row.ours_baseline],
                "ours_ratio": row.ours_ratio,
                "paper": [row.paper_symmetric, row.paper_baseline],
                "paper_ratio": row.paper_ratio,
            }
            for row in table4_rows(symmetric, baseline)
        ],
        "work_incl_impacts_J": [symmetric.work_incl_impacts_J, baseline.work_incl_impacts_J],
        "impact_loss_J": [symmetric.impact_loss_J, baseline.impact_loss_J],
        "paper_solve_s": list(TABLE4.solve_s),
    }
