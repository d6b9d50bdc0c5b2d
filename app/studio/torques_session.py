"""Torque feed-forward in the studio: compute τ for the current motion in a named worker
thread, with progress, over a warm pool of worker processes on every core (started by the
first computation long enough to pay for it, MIN_POOL_SAMPLES; a shorter motion is solved in
the thread, same torques; kept for the next ones, closed with the studio). The result goes to
the state (`StudioState.set_torques`); the samples the robot cannot follow are named in the
status line. τ depends on the plan only: editing a coefficient never recomputes it.
"""

from __future__ import annotations

import io
import logging
import threading

import viser

from app.core.dynamics.parallel import MIN_POOL_SAMPLES, FeedForwardPool
from app.core.dynamics.peaks import torque_peaks
from app.core.dynamics.wbc import FeedForward, torque_feedforward
from app.core.errors import StudioError
from app.core.motions.trajectory import Trajectory
from app.core.robot.model import RobotModel
from app.core.servo.files import write_torque_csv
from app.studio.file_names import file_slug
from app.studio.notifier import Notifier, failure_told
from app.studio.signals import Signal
from app.studio.state import Motion, StudioState
from app.studio.torque_text import torque_summary
from panels.compensation_folder import CompensationFolder
from panels.torques_panel import TorquesPanel

log = logging.getLogger(__name__)


class TorquesSession:
    """Owns the torques' rows of the Compensation folder and the feed-forward's pool."""

    def __init__(self, state: StudioState, notifier: Notifier, folder: CompensationFolder) -> None:
        self._state, self._notifier = state, notifier
        self.panel = TorquesPanel(folder, self)
        self.done: Signal[FeedForward | None] = Signal("torques_done")
        """Emitted when a torque computation ends: its result, or None if it failed or was
        dropped because the motion changed meanwhile."""
        self._worker: threading.Thread | None = None
        self._pool: FeedForwardPool | None = None
        """The feed-forward's worker processes, started by the first computation."""
        self.pool_min_samples = MIN_POOL_SAMPLES
        """Motions with fewer samples are solved in the thread, without the pool."""
        self._pool_lock = threading.Lock()
        self._closed = False
        state.on_motion.connect(self._on_motion)
        state.work.on_torques.connect(self._on_torques)

    def _on_motion(self, motion: Motion | None) -> None:
        self.panel.status.content = (
            "Compute the torques of this motion."
            if motion is not None
            else "Generate or build a motion first."
        )
        if motion is not None and "torques" in motion.then:  # the one-click pipeline
            self.compute_torques()

    def _on_torques(self, feedforward: FeedForward) -> None:
        robot, trajectory = self._state.robot, self._state.trajectory
        if robot is not None and trajectory is not None:
            peaks = torque_peaks(robot, trajectory, feedforward)
            self.panel.status.content = torque_summary(peaks, trajectory)

    # --- computing (TorquesActions) ------------------------------------------------------------

    def compute_torques(self, client: viser.ClientHandle | None = None) -> None:
        """Start the torque feed-forward of the current motion in a worker thread; the end is
        announced by `done`."""
        with self._state.lock:
            robot, trajectory = self._state.robot, self._state.trajectory
        if robot is None or trajectory is None:
            self._fail("No motion", "generate or build a motion first", client)
            return
        if self._worker is not None and self._worker.is_alive():
            return
        self.panel.show_progress(0.0)
        self.panel.status.content = (
            f"Computing τ for **{trajectory.name}** ({trajectory.n_samples} samples)…"
        )
        self._worker = threading.Thread(
            target=self._compute, args=(robot, trajectory, client), name="feedforward", daemon=True
        )
        self._worker.start()

    def _compute(
        self, robot: RobotModel, trajectory: Trajectory, client: viser.ClientHandle | None
    ) -> None:
        kept: FeedForward | None = None
        try:
            with failure_told(self._fail, "Torque feed-forward failed", client, log):
                samples = trajectory.n_samples
                pool = self._warm_pool() if samples >= self.pool_min_samples else None
                result = torque_feedforward(
                    robot, trajectory, progress=self.panel.show_progress, pool=pool
                )
                with self._state.lock:  # dropped if the motion changed meanwhile
                    work = self._state.work
                    if robot is self._state.robot and work.set_torques(result, trajectory):
                        kept = result
        finally:
            self.panel.show_progress(None)
            self.done.emit(kept)

    def export_torques(self, client: viser.ClientHandle | None = None) -> bytes | None:
        feedforward = self._state.work.torques
        if feedforward is None:
            self._fail("Nothing to export", "compute the torque feed-forward first", client)
            return None
        buffer = io.StringIO()
        write_torque_csv(buffer, feedforward)
        content = buffer.getvalue().encode()
        if client is not None:
            client.send_file_download(f"{file_slug(feedforward.trajectory_name)}_tau.csv", content)
        return content

    # --- the pool ------------------------------------------------------------------------------

    @property
    def feedforward_pool(self) -> FeedForwardPool | None:
        """The warm worker pool of the torque feed-forward, None before the first use."""
        return self._pool

    def _warm_pool(self) -> FeedForwardPool:
        """The studio's pool of feed-forward workers (one per core), started on first use."""
        with self._pool_lock:
            if self._closed:
                raise StudioError("the studio is shutting down")
            if self._pool is None:
                self._pool = FeedForwardPool()
            return self._pool

    def close(self) -> None:
        with self._pool_lock:
            self._closed = True
            pool, self._pool = self._pool, None
        if pool is not None:
            pool.close()

    def _fail(self, title: str, body: str, client: viser.ClientHandle | None) -> None:
        self.panel.status.content = f"⚠️ {body}"
        self._notifier.error(title, body, client)
