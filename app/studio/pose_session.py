"""Drag-to-pose in the studio: gizmos on the feet and pelvis, whole-body IK, the balance
overlay, and the Pose panel's buttons.

Gizmo drags arrive on viser's thread pool, at most every 50 ms per tab, possibly from several
tabs at once. Only the latest target per handle matters: a Coalescer keeps it, and a target
that has not been solved yet is replaced by a newer one, so a backlog of stale drags is never
worked through and no callback waits behind another tab's solve.

A drag out of reach says what holds the pose back on its first miss, every few events and at
the release (app.core.posing.drag.EXPLAIN_EVERY); between them the status keeps the last
"held back by" lines beside the fresh misses. Let go, a handle goes back onto its link (out of
reach it would otherwise hang where the hand left it, away from the foot it moves).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import viser

from app.core.errors import StudioError
from app.core.posing.drag import Posing
from app.core.posing.ik import OUT_OF_REACH, IkResult
from app.core.posing.ik_verdict import explains
from app.core.posing.ready_pose import ready_pose
from app.core.robot.model import RobotModel
from app.studio.coalesce import Coalescer
from app.studio.notifier import Notifier
from app.studio.state import STANCES, Display, LoadedRobot, Pose, Stance, StudioState
from app.views.balance_view import BalanceView
from app.views.drag_handles import DragHandles
from app.views.roots import AlternatingRoot
from panels.pose_panel import PosePanel


class PoseSession:
    """Owns the Pose panel, the drag handles and the balance overlay of the loaded robot."""

    def __init__(self, server: viser.ViserServer, state: StudioState, notifier: Notifier) -> None:
        self._server, self._state, self._notifier = server, state, notifier
        self.panel = PosePanel(server.gui, self)
        self.posing: Posing | None = None
        self.handles: DragHandles | None = None
        self.balance: BalanceView | None = None
        self.last_result: IkResult | None = None
        self._held_back: tuple[str, ...] = ()
        """The "held back by" lines of the last result that looked for them (module docstring)."""
        self._data: pin.Data | None = None
        """Pinocchio data of the loaded robot, for the handles' placements."""
        self._handle_links: tuple[str, ...] = ()
        """The links the drag handles sit on."""
        self._hidden_for_playback = False
        self._roots = AlternatingRoot("/pose")
        self._drags: Coalescer[str, tuple[np.ndarray, bool]] = Coalescer(self._solve_drag)
        state.on_robot.connect(self._on_robot)
        state.on_pose.connect(self._on_pose)
        state.on_display.connect(self._on_display)

    # --- state changes ----------------------------------------------------------------------

    def _on_robot(self, loaded: LoadedRobot) -> None:
        robot = loaded.robot
        for overlay in (self.handles, self.balance):
            if overlay is not None:
                overlay.remove()
        self.posing = Posing(robot, com_in_support=self.panel.com_in_support.value)
        self._data = robot.model.createData()
        lower, upper = robot.bounds_m(robot.q_neutral, robot.model.createData())
        frames = {
            "left": robot.feet[0].link,
            "right": robot.feet[1].link,
            "pelvis": robot.tree.root,
        }
        self._handle_links = tuple(frames.values())
        root = self._roots.next()
        self.handles = DragHandles(
            self._server,
            frames,
            0.15 * float(upper[2] - lower[2]),
            self.request_drag,
            root=f"{root}/drag",
        )
        self.handles.set_visible(self.panel.handles.value)
        self._hidden_for_playback = False
        self.balance = BalanceView(self._server, robot.n_actuated, root=f"{root}/balance")
        self.last_result = None

    def _on_display(self, display: Display) -> None:
        """An opened project's Pose toggles: the panel, the handles and the IK follow them."""
        if display.origin != "project":
            return
        settings = display.settings
        self.panel.show_toggles(settings.handles, settings.keep_com)
        self._apply_com_in_support(settings.keep_com)
        self._apply_handles_visible(settings.handles)

    def _on_pose(self, pose: Pose) -> None:
        posing, handles, balance, data = self.posing, self.handles, self.balance, self._data
        if posing is None or handles is None or balance is None or data is None:
            return
        if pose.dragged is None:
            self.last_result = None
        posing.stance = pose.stance
        self._place_handles(pose.q, skip=pose.dragged)
        balance.update(posing.balance(pose.q))
        self.panel.show_stance(pose.stance)
        self._show_status(self._status(pose.stance))
        playing = pose.origin == "playback"
        if playing != self._hidden_for_playback:  # no gizmos over a motion being played
            self._hidden_for_playback = playing
            handles.set_visible(self.panel.handles.value and not playing)

    def _place_handles(self, q: np.ndarray, skip: str | None) -> None:
        """The handles onto their links at q, but the one a drag holds (`skip`)."""
        posing, handles, data = self.posing, self.handles, self._data
        if posing is None or handles is None or data is None:
            return
        robot = posing.robot
        pin.framesForwardKinematics(robot.model, data, q)  # only the handles' links
        handles.place(
            {link: data.oMf[robot.link_frame_ids[link]].homogeneous for link in self._handle_links},
            skip=skip,
        )

    # --- dragging ---------------------------------------------------------------------------

    def request_drag(self, which: str, T_world: np.ndarray, released: bool = False) -> None:
        """A handle ("left", "right", "pelvis") moved to T_world (released: the drag ends
        there): solve IK and show the pose. NaN targets or an unknown handle (a crafted
        client) are ignored."""
        if which not in ("left", "right", "pelvis"):
            return
        T_world = np.asarray(T_world, dtype=float)
        if T_world.shape != (4, 4) or not np.all(np.isfinite(T_world)):
            return
        self._drags.submit(which, (T_world, bool(released)))

    @property
    def drags_idle(self) -> bool:
        """No drag waiting to be solved, none being solved."""
        return self._drags.idle

    def _solve_drag(self, which: str, request: tuple[np.ndarray, bool]) -> None:
        T_world, released = request
        state = self._state
        with state.lock:
            posing, pose = self.posing, state.pose
            if posing is None or pose is None or posing.robot is not state.robot:
                return
            posing.stance = pose.stance
            result = posing.drag(pose.q, which, T_world, explain=True if released else None)
            self._apply(posing.robot, result, posing.stance, f"drag:{which}")
            if released:  # let go out of reach: the handle goes back onto its link
                self._place_handles(result.q, skip=None)

    def _apply(self, robot: RobotModel, result: IkResult, stance: Stance, origin: str) -> None:
        with self._server.atomic():
            # Known before the pose is shown, so that _on_pose writes the status once.
            self.last_result = result
            if result.explained:
                self._held_back = tuple(line for line in result.shortfall if explains(line))
            self._state.set_pose(result.q, stance, origin, robot)
            if self.last_result is not result:  # not a drag: _on_pose cleared it
                self.last_result = result
                self.panel.show_status(self._status(stance))

    # --- buttons (PoseActions) ----------------------------------------------------------------

    def reset_pose(self) -> None:
        with self._state.lock:
            robot = self._state.robot
            if robot is not None:
                with self._server.atomic():
                    self._state.set_pose(robot.q_neutral.copy(), "both", "button", robot)

    def ready_pose(self) -> None:
        """Knees bent, pelvis lowered, feet where they stand (app.core.posing.ready_pose)."""
        with self._state.lock:
            robot = self._state.robot
            if robot is None:
                return
            try:
                ready = ready_pose(robot)
            except StudioError as error:
                self.panel.show_status(f"⚠️ {error}")
                self._notifier.error("No ready pose", str(error))
                return
            with self._server.atomic():
                self._state.set_pose(ready.q, "both", "button", robot)

    def snap_feet(self) -> None:
        with self._state.lock:
            posing, pose = self.posing, self._state.pose
            if posing is None or pose is None or posing.robot is not self._state.robot:
                return
            result = posing.snap_feet_to_ground(pose.q)
            self._apply(posing.robot, result, "both", "button")

    def swap_stance(self) -> None:
        with self._state.lock:
            pose = self._state.pose
            if pose is not None:
                swapped = {"left": "right", "right": "left", "both": "both"}[pose.stance]
                self._state.set_stance(swapped)  # type: ignore[arg-type]

    def set_stance(self, stance: str) -> None:
        if stance in STANCES:
            self._state.set_stance(stance)

    def set_com_in_support(self, on: bool) -> None:
        self._state.set_display("panel", keep_com=bool(on))
        self._apply_com_in_support(on)

    def set_handles_visible(self, visible: bool) -> None:
        self._state.set_display("panel", handles=bool(visible))
        self._apply_handles_visible(visible)

    def _apply_com_in_support(self, on: bool) -> None:
        with self._state.lock:
            if self.posing is not None:
                self.posing.com_in_support = bool(on)

    def _apply_handles_visible(self, visible: bool) -> None:
        with self._state.lock:
            if self.handles is not None:
                self.handles.set_visible(bool(visible))

    # --- status -----------------------------------------------------------------------------

    def _show_status(self, text: str) -> None:
        """Write the Pose panel's status only when its text changes (drag events mostly
        repeat it, and viser re-parses the markdown on every assignment)."""
        if text != self.panel.status.content:
            self.panel.show_status(text)

    def _status(self, stance: str) -> str:
        result = self.last_result
        lines = [f"Stance: **{stance}**"]
        if result is not None:
            if result.reached:
                lines.append("Target reached ✓")
            else:  # what is missed by how much, and what holds the pose back
                lines.append("**Closest reachable pose** (target not reached):")
                # a drag event between explanations: the last ones stand
                held_back = () if result.explained else self._held_back
                lines.extend(f"- {reason}" for reason in result.shortfall + held_back)
                # A blank line ends the list: markdown would take the lines below as a
                # continuation of its last item (the CoM margin shown as a held-back reason).
                lines.append("")
            lines.append(f"CoM margin in support: {result.com_margin_m * 1000:.0f} mm")
            if result.joints_near_limit:
                lines.append("Near a limit: " + ", ".join(result.joints_near_limit))
            lines.extend(
                f"⚠️ {warning}"
                for warning in result.warnings
                if not (result.shortfall and OUT_OF_REACH in warning)  # said above
            )
        return "  \n".join(lines)
