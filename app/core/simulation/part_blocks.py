"""Servo parts' samples a block at a time in C, the current limit checked (numpy and mujoco).

Within its limits a part's law (`part_law`) is the ideal servo's with the part's K, dead band
and stall torque and no set-point slew, its back-EMF, viscous friction, Coulomb friction (m1)
and rotor in the joints' MuJoCo damping, frictionloss and armature: MuJoCo's actuators
(`servo_law.actuators_xml`) apply it in C and a block of samples steps in one
`mujoco.rollout` (`blocks.Blocks`). What is not affine stays in Python, per tick, after the
rollout, on the states it returns:

- the energy: each tick's torque τ (the actuators' law on the state the tick starts from and
  its set point) and speed q̇ give I = τ/kt − (kt/R)·q̇ and V = τ·R/kt, summed over the block
  at once (`PartLoop.account`, the per-tick loop's sums);
- the firmware's current limit |τ − (kt²/R)·q̇| ≤ kt·I_lim, which no actuator can apply (its
  bounds move with q̇): where a tick of the block breaks it, the samples before the one whose
  hold reached the limit are kept as the rollout made them, the live MjData is put at that
  sample's state (warm-started from its forward pass's accelerations: the rollout keeps no
  warm start), and that sample and those after it run the law in Python at every tick
  (`PartLoop`, actuators off, torque in qfrc_applied, as with `servo_in_mujoco=False`) until
  a sample's hold stays within the limit; the rest of the block is then tried in C again, a
  few samples first (`RETRY_SAMPLES`), as the ticks a try makes past the limit are lost.

A hold that is not recorded (the settling) is the same: in C, or, where it reaches the limit,
again from its start in Python at every tick. BAM's m6 friction (its budget from the
constraint forces of every tick) is not stepped here: a law with m6 joints runs in Python
(`engine`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from app.core.simulation.blocks import Blocks
from app.core.simulation.part_law import PartLoop
from app.core.simulation.recording import FORWARD_TOLERANCE, Recorder
from app.core.simulation.servo_law import Setpoints

RETRY_SAMPLES = 4
"""After a sample that reached the limit, C is tried again on this many samples, twice as many
after each try that stays within the limit, and whole blocks again past `MAX_RETRY_SAMPLES`:
the ticks a try makes past the limit are lost, so tries are kept short where the limit acts
often."""
MAX_RETRY_SAMPLES = 32


class PartBlocks(Blocks):
    """`Blocks` for servo parts (module docstring): energy accounted per tick, the current
    limit checked and, where it acts, the samples that reach it stepped in Python by `loop`."""

    def __init__(
        self,
        m: Any,
        d: Any,
        ctrl_joint: np.ndarray,
        ticks: int,
        setpoints: Setpoints,
        commands: np.ndarray,
        actuated: tuple[np.ndarray, np.ndarray],
        linear_hold: bool,
        loop: PartLoop,
    ) -> None:
        super().__init__(m, d, ctrl_joint, ticks, setpoints, commands, actuated, linear_hold)
        import mujoco

        self.loop = loop
        law = loop.part
        self._act_qpos_joint = actuated[0]
        self._limited = np.isfinite(law.current_limit_A)
        self._emf = law.back_emf_Nms_per_rad[self._limited]
        self._kt_limit = (law.kt_Nm_per_A * law.current_limit_A)[self._limited]
        self._flags_python = self._flags_steps | int(mujoco.mjtDisableBit.mjDSBL_ACTUATION)
        self._chunk: int | None = None  # samples per try in C; None: to the block's end
        self._warm_from_forward = False

    def hold(self, command: np.ndarray, n: int) -> None:
        """Hold `command` for `n` ticks from the live MjData, not recorded (the settling),
        energy accounted: in C, or, where a tick reaches a current limit, every tick in
        Python."""
        if n <= 0:
            return
        state0, warm0 = self.state(), self.d.qacc_warmstart.copy()
        setpoint0 = self.setpoints.setpoint.copy()
        rows = self.setpoints.hold(command, n)
        control = np.tile(command, (n, 1)) if rows is None else rows
        control = np.ascontiguousarray(control[:, self.ctrl_joint])
        states = self._steps(state0, control)
        tau, dq = self._ticks_law(self._starts(state0, states), control)
        if self._first_limited(tau, dq) < 0:
            self.loop.account(tau, dq)
            self.torque_before = np.zeros(self.m.nv)
            self.torque_before[self._actuated_dof] = tau[-1]
            return
        self._restore(state0, warm0, setpoint0)
        self._sync_loop()
        self.loop.set_command(command)
        self.m.opt.disableflags = self._flags_python
        for _ in range(n):
            self._python_tick()
        self._python_done()

    def run(self, k0: int, k1: int, recorder: Recorder) -> None:
        """`Blocks.run` with each tick's energy accounted and the current limit kept (module
        docstring)."""
        k = k0
        while k < k1:
            end = k1 if self._chunk is None else min(k1, k + self._chunk)
            k = self._try_c(k, end, recorder)
            if k == end:  # in C throughout: longer tries again, up to whole blocks
                if self._chunk is not None:
                    self._chunk = None if self._chunk >= MAX_RETRY_SAMPLES else 2 * self._chunk
                continue
            self._chunk = RETRY_SAMPLES
            while k < k1:  # a sample that reached the limit: Python until one that does not
                limited = self._python_sample(k, recorder)
                k += 1
                if not limited:
                    break

    def _try_c(self, k0: int, k1: int, recorder: Recorder) -> int:
        """Samples [k0, k1) in C, or those before the first whose hold reaches a current
        limit (the live MjData then at that sample's state); returns where it stopped."""
        holds = min(k1, len(self.commands) - 1) - k0
        state0 = self.state()
        if holds <= 0:
            self._record(k0, k1, state0, None, None, recorder)
            return k1
        warm0, setpoint0 = self.d.qacc_warmstart.copy(), self.setpoints.setpoint.copy()
        control = self._controls(k0, k0 + holds)
        states = self._steps(state0, control)
        tau, dq = self._ticks_law(self._starts(state0, states), control)
        first = self._first_limited(tau, dq)
        if first < 0:
            self.loop.account(tau, dq)
            self._record(k0, k1, state0, states, tau[self.ticks - 1 :: self.ticks], recorder)
            return k1
        bad = k0 + first // self.ticks  # the holds before it stand, the rest is stepped again
        n = (bad - k0) * self.ticks
        if n:
            self.loop.account(tau[:n], dq[:n])
            self._record(
                k0, bad, state0, states[:n], tau[self.ticks - 1 : n : self.ticks], recorder
            )
            setpoint = np.empty(len(self.commands[0]))
            setpoint[self.ctrl_joint] = control[n - 1]
            self._mj.mj_setState(self.m, self.d, states[n - 1], self._kind)
            self._warm_from_forward = True  # the rollout keeps no warm start of that step
            self.setpoints.restart(setpoint)
        else:
            self._restore(state0, warm0, setpoint0)
        return bad

    def _ticks_law(self, starts: np.ndarray, control: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Each tick's actuator torque and speed (rows, n) from the states the ticks start
        from (rows, nstate) and their ctrl (rows, nu)."""
        nq = self.m.nq
        tau = self._law(starts[:, 1 : 1 + nq], control)
        dq = starts[:, 1 + nq + self._actuated_dof]
        return tau, dq

    def _first_limited(self, tau: np.ndarray, dq: np.ndarray) -> int:
        """The first tick whose torque the current limit would clip (`PartLoop.torque`'s
        test), −1 if none."""
        if not len(self._kt_limit):
            return -1
        emf = self._emf * dq[:, self._limited]
        mine = tau[:, self._limited]
        over = ((mine < emf - self._kt_limit) | (mine > emf + self._kt_limit)).any(axis=1)
        return int(over.argmax()) if over.any() else -1

    def _restore(self, state: np.ndarray, warmstart: np.ndarray, setpoint: np.ndarray) -> None:
        """The live MjData and the set points back where a block started."""
        self._mj.mj_setState(self.m, self.d, state, self._kind)
        self.d.qacc_warmstart[:] = warmstart
        self.setpoints.restart(setpoint)

    def _python_sample(self, k: int, recorder: Recorder) -> bool:
        """Sample k with the law in Python at every tick (`engine`'s step loop with
        `servo_in_mujoco=False`, the actuators off): recorded after a forward pass under the
        torque of the step before, then held; whether a tick reached a current limit."""
        mj, m, d, commands, opt = self._mj, self.m, self.d, self.commands, self.m.opt
        self._sync_loop()
        d.qfrc_applied[self._actuated_dof] = self.torque_before[self._actuated_dof]
        opt.disableflags, tolerance, opt.tolerance = (
            self._flags_forward,
            opt.tolerance,
            FORWARD_TOLERANCE,
        )
        mj.mj_forward(m, d)
        opt.tolerance = tolerance
        if self._warm_from_forward:  # the next step's solver starts from this sample's qacc
            d.qacc_warmstart[:] = d.qacc
            self._warm_from_forward = False
        recorder.record(k)
        if k == len(commands) - 1:  # the motion's last sample: recorded, not held
            d.qfrc_applied[:] = 0.0
            opt.disableflags = self._flags_steps
            return False
        opt.disableflags = self._flags_python
        limited = self.loop.limited_ticks
        command, after = commands[k], commands[min(k + 1, len(commands) - 1)]
        step = (after - command) / self.ticks if self.linear_hold else None
        if step is None:
            self.loop.set_command(command)
        for i in range(1, self.ticks + 1):
            if step is not None:
                self.loop.set_command(command + i * step)
            self._python_tick()
        recorder.tau[k] = self.loop.tau
        self._python_done()
        return self.loop.limited_ticks > limited

    def _python_tick(self) -> None:
        """One physics step with the Python law's torque in qfrc_applied."""
        d = self.d
        d.qfrc_applied[self._actuated_dof] = self.loop.torque(d.qpos[self._act_qpos_joint])
        self._mj.mj_step(self.m, d)

    def _sync_loop(self) -> None:
        """The Python law takes up the set point where the blocks' left it."""
        self.loop.setpoint = self.setpoints.setpoint.copy()
        self.loop.command = self.loop.setpoint.copy()
        self.loop.settled = True

    def _python_done(self) -> None:
        """Back to the actuators: the blocks' set points and torque of the step before are the
        Python law's; qfrc_applied cleared."""
        self.setpoints.restart(self.loop.setpoint)
        self.torque_before = np.zeros(self.m.nv)
        self.torque_before[self._actuated_dof] = self.loop.tau
        self.d.qfrc_applied[:] = 0.0
        self.m.opt.disableflags = self._flags_steps
