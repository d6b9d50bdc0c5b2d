"""The gait planner's words: one solve and the last good gaits (`Solve`, `GaitResults`), the
status line after a solve, the stage of a mesh-refining solve, and the results table beside the
paper's Table 4 (markdown for the Gait panel)."""

from __future__ import annotations

import dataclasses

from app.core.collocation.gait_problem import COARSE_KNOTS
from app.core.collocation.job_key import GaitProblemKey
from app.core.collocation.result import GaitResult
from app.core.collocation.settings import GaitSettings
from app.core.collocation.table4 import WHAT_IS_COMPARED, table4_rows
from app.core.papers import TABLE4
from app.core.robot.model import RobotModel


@dataclasses.dataclass(frozen=True)
class Solve:
    """One solve: what was asked, and (when it ended) what came back."""

    job_id: str
    settings: GaitSettings
    robot: RobotModel | None = None
    """The robot it plans for (its result is dropped if another is loaded meanwhile)."""
    started_s: float = 0.0
    """time.monotonic() at the click."""
    kind: str = ""
    """What is solved, as the status line says it ("symmetric gait", …)."""
    refines: bool = False
    """The worker solves COARSE_KNOTS first and starts this mesh from it (a first solve of
    more knots than REFINE_ABOVE_KNOTS): its progress comes in two stages."""
    warm: bool = False
    """The worker holds a converged gait of this structure: the solve starts warm from it, and
    restarts cold after WARM_ITERATIONS_BEFORE_FALLBACK iterations without converging."""
    key: GaitProblemKey | None = None
    ended_s: float = 0.0
    result: GaitResult | None = None
    error: str = ""
    """Why the solve failed (worker crash, refused settings) or "cancelled"."""


@dataclasses.dataclass
class GaitResults:
    symmetric: GaitResult | None = None
    """Last good (converged) symmetric gait."""
    baseline: GaitResult | None = None
    """Last good (converged) baseline gait."""

    def of(self, baseline: bool) -> GaitResult | None:
        return self.baseline if baseline else self.symmetric


def results_table(results: GaitResults, stale: bool) -> str:
    """Both last good gaits beside the paper's Table 4 (markdown); `stale`: the settings
    changed since the last solve."""
    sym, base = results.symmetric, results.baseline

    def cell(result: GaitResult | None, attribute: str, fmt: str) -> str:
        return fmt.format(getattr(result, attribute)) if result is not None else "—"

    low, high = TABLE4.solve_s
    rows = [
        "| | this planner | baseline | paper (sym. / prev.) |",
        "|---|---|---|---|",
        f"| solve time [s] | {cell(sym, 'solve_s', '{:.1f}')} | {cell(base, 'solve_s', '{:.1f}')} | {low:g}–{high:g} |",
        f"| max \\|τ\\| [N·m] | {cell(sym, 'max_abs_tau_Nm', '{:.2f}')} | {cell(base, 'max_abs_tau_Nm', '{:.2f}')} "
        f"| {TABLE4.max_abs_tau_Nm[0]} / {TABLE4.max_abs_tau_Nm[1]} |",
        f"| SR incl. impacts | {cell(sym, 'sr_incl_impacts', '{:.3f}')} | {cell(base, 'sr_incl_impacts', '{:.3f}')} "
        f"| {TABLE4.sr[0]} / {TABLE4.sr[1]} |",
        f"| impact loss [J] | {cell(sym, 'impact_loss_J', '{:.2f}')} | {cell(base, 'impact_loss_J', '{:.2f}')} | |",
    ]
    if sym is not None and base is not None:
        for row in table4_rows(sym, base):
            rows.append(
                f"| ratio sym./baseline, {row.name} | {row.ours_ratio:.2f} | | {row.paper_ratio:.2f} |"
            )
    for result, label in ((sym, "this planner"), (base, "baseline")):
        if result is not None:
            lsp, rsp = result.step_lengths_m
            rows.append(f"| steps LSP / RSP [m] ({label}) | {lsp:.3f} / {rsp:.3f} | | |")
            check = result.bound_check
            if check is not None:
                verdict = "hold" if check.holds else "**do not hold**"
                rows.append(
                    f"| bounds between knots ({label}, {check.samples} samples) | {verdict} | | |"
                )
    if sym is not None:
        rows.append(f"| slack0 | {sym.slack0:+.3f} | | |")
    rows.append(
        f"| symmetry residuals: exchange / periodicity | {_residuals(sym)} | {_residuals(base)} | |"
    )
    note = "\n\n⚠️ The settings changed since this solve: results are stale." if stale else ""
    return "\n".join(rows) + f"\n\n*Compared:* {WHAT_IS_COMPARED}." + note


def status_line(solve: Solve, results: GaitResults) -> str:
    kept = " The last good gait is kept." if results.of(solve.settings.baseline) else ""
    if solve.error == "cancelled":
        return "Cancelled." + kept
    if solve.error:
        return f"⚠️ {solve.error}{kept}"
    result = solve.result
    assert result is not None
    waited = solve.ended_s - solve.started_s
    parts = f"IPOPT {result.solve_s:.1f} s, {result.iterations} iterations"
    if solve.warm and not result.restarted_cold:
        parts += ", warm start from the last gait"
    if waited > result.solve_s:
        parts += f"; worker start and NLP build {waited - result.solve_s:.1f} s"
    restart = ""
    if result.restarted_cold:
        restart = (
            f" 🔄 The warm start from the last gait did not converge in "
            f"{result.warm_iterations_before_cold} iterations, so the solve restarted cold "
            "from the built-in guess"
        )
        restart += "." if result.converged else ", which did not converge either."
    if result.converged:
        return f"Solved in {waited:.1f} s ({parts}).{restart}"
    blame = f" {result.blame}" if result.blame else ""
    return f"⚠️ Not solved after {waited:.1f} s: {result.status} ({parts}).{restart}{blame}{kept}"


def stage_words(solve: Solve, stage: int) -> str:
    """Which stage a mesh-refining solve is in ("" for a single-stage solve)."""
    if not solve.refines:
        return ""
    if stage == 1:
        return f", stage 1 of 2: the coarse {COARSE_KNOTS}-knot solve"
    return f", stage 2 of 2: {solve.settings.knots} knots from the coarse solve"


def _residuals(result: GaitResult | None) -> str:
    if result is None:
        return "—"
    return f"{result.exchange_residual:.1e} / {result.periodicity_residual:.1e}"
