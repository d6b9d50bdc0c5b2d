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

from app.core.collocation.result import GaitResult
from app.core.papers import TABLE4

WHAT_IS_COMPARED = (
    "ours: planned max |τ| and planned mechanical work (positive joint work + impact losses) "
    "/ (M g d) of a rigid model; paper (Table 4, section 5.3): max joint input of its planned "
    "gaits and SR from the real robot's measured motor energy — compare the ratios, not the "
    "absolute values"
)


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


def table4_comparison(symmetric: GaitResult, baseline: GaitResult) -> dict[str, object]:
    """The comparison as JSON-able values."""
    return {
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
