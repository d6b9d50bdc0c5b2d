"""The one click's progress, shown under its button in the Gait panel: which stage runs
(planning → walking → torques → simulating), which are done, and the time since the click.

Each stage reports in its own panel too (the gait's convergence, the Compensation panel's
bars); this line is where the user who clicked looks. It follows the stages through the
signals the features already announce, so no feature calls another.
"""

from __future__ import annotations

import threading
import time
from typing import Any

import viser

from app.studio.signals import Signal
from app.studio.state import Motion, StudioState

STAGES = ("planning", "walking", "torques", "simulating")
DONE = "done"
WHERE = {
    "planning": "the solve's progress is above",
    "walking": "",
    "torques": "the Compensation panel shows its bar",
    "simulating": "the Compensation panel's Simulation folder shows its bar",
}


class PipelineProgress:
    """A markdown line in the Gait folder for the one-click pipeline."""

    def __init__(
        self,
        gui: viser.GuiApi,
        folder: viser.GuiFolderHandle,
        state: StudioState,
        signals: dict[str, Signal[Any]],
    ) -> None:
        """signals: "started" (str: the first stage, when the click is taken), "iteration"
        (int, a solve's progress), "solved" (the solve that ended), "torques" (FeedForward or
        None), "simulated" (a Simulation), "refused" (str: why a simulation could not start)."""
        with folder:
            self.line = gui.add_markdown("")
        self._lock = threading.Lock()
        self.stage: str | None = None
        """The stage under way (or DONE), None before any click or after a stop."""
        self._clicked_s = 0.0
        self.shown: Signal[str] = Signal("pipeline_stage_shown")
        """Emitted with the stage (or DONE, or "stopped") after the line shows it."""
        signals["started"].connect(self._on_started)
        signals["iteration"].connect(self._on_iteration)
        signals["solved"].connect(self._on_solved)
        signals["torques"].connect(self._on_torques)
        signals["simulated"].connect(self._on_simulated)
        signals["refused"].connect(self._on_refused)
        state.on_motion.connect(self._on_motion)

    # --- events ------------------------------------------------------------------------------

    def _on_started(self, first: str) -> None:
        with self._lock:
            self.stage, self._clicked_s = None, time.monotonic()
            self._advance(first, "" if first == "planning" else "the last gait still fits")

    def _on_iteration(self, iteration: int) -> None:
        with self._lock:
            if self.stage == "planning":
                self._show("planning", f"IPOPT iteration {iteration}")

    def _on_solved(self, solve: Any) -> None:
        with self._lock:
            if self.stage != "planning":
                return  # not the one click's solve, or its walk already started
            result = getattr(solve, "result", None)
            if result is None or not result.converged:
                self._stop("planning", getattr(solve, "error", "") or "the gait did not converge")

    def _on_motion(self, motion: Motion | None) -> None:
        with self._lock:
            if self.stage not in ("planning", "walking"):
                return
            if motion is not None and "torques" in motion.then:
                self._advance("torques")
            else:
                self._stop(self.stage or "walking", "another motion replaced the walk")

    def _on_torques(self, result: object) -> None:
        with self._lock:
            if self.stage != "torques":
                return
            if result is None:
                self._stop("torques", "see the Compensation panel")
            else:
                self._advance("simulating")

    def _on_simulated(self, simulation: Any) -> None:
        with self._lock:
            if self.stage != "simulating":
                return
            error = getattr(simulation, "error", "")
            if error:
                self._stop("simulating", error)
            else:
                self._advance(DONE)

    def _on_refused(self, why: str) -> None:
        with self._lock:
            # The one click's simulation starts as soon as the torques' estimate is in, which
            # can be before the torques' own signal moves this line to "simulating".
            if self.stage in ("torques", "simulating"):
                self._stop("simulating", why)

    # --- the line ----------------------------------------------------------------------------

    def _advance(self, stage: str, detail: str = "") -> None:
        order = (*STAGES, DONE)
        if self.stage is not None and order.index(stage) <= order.index(self.stage):
            return  # stages only move forwards (signals can arrive late)
        self._show(stage, detail or WHERE.get(stage, ""))

    def _show(self, stage: str, detail: str) -> None:
        self.stage = stage
        waited = time.monotonic() - self._clicked_s
        if stage == DONE:
            text = f"**One click** ✅ planned, walked, torques, simulated — {waited:.0f} s."
        else:
            at = STAGES.index(stage)
            marks = [
                f"✅ {name}" if i < at else (f"⏳ **{name}**" if i == at else name)
                for i, name in enumerate(STAGES)
            ]
            text = (
                f"**One click**, stage {at + 1} of {len(STAGES)}: " + " → ".join(marks) + "  \n"
                f"{waited:.0f} s since the click" + (f"; {detail}" if detail else "") + "."
            )
        self.line.content = text
        self.shown.emit(stage)

    def _stop(self, stage: str, why: str) -> None:
        self.stage = None
        self.line.content = f"**One click** ⚠️ stopped at {stage}: {why}."
        self.shown.emit("stopped")
