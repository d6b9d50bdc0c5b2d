"""The physics of a simulation a block of samples at a time (`Stepper`, used by `engine`):
the servo law in MuJoCo's actuators (`blocks`, `part_blocks`) or a law in Python at every tick
(`ServoLoop`, `PartLoop`), the balance feedback correcting each sample's command first."""

from __future__ import annotations

from typing import Any

import numpy as np

from app.core.simulation.balance_feedback import Balancer
from app.core.simulation.blocks import Blocks
from app.core.simulation.engine_io import EngineInput
from app.core.simulation.part_blocks import PartBlocks
from app.core.simulation.part_law import PartLaw, PartLoop
from app.core.simulation.recording import FORWARD_TOLERANCE, Recorder
from app.core.simulation.servo_law import ServoLoop, Setpoints

__all__ = ["Stepper", "contiguous", "split_spans"]


class Stepper:
    """The physics a block of samples at a time: the servo law in MuJoCo's actuators
    (`blocks.Blocks`: set points as ctrl, every tick in C; servo parts' `PartBlocks`), or a
    law in Python at every tick (`ServoLoop`, `PartLoop`) into qfrc_applied, a sample at a
    time. With the balance feedback, a block is one sample: its command is corrected first
    (`Balancer`)."""

    def __init__(self, inp: EngineInput, m: Any, d: Any, ctrl_joint: np.ndarray, ticks: int):
        import mujoco

        self.inp, self.m, self.d, self.ctrl_joint, self.ticks = inp, m, d, ctrl_joint, ticks
        self._mj = mujoco
        self.in_mujoco = len(ctrl_joint) > 0
        self.commands = np.asarray(inp.q_cmd_rad, dtype=float)
        self.balancer: Balancer | None = None
        if inp.balance is not None:  # it corrects the commands in place: a copy of them
            self.balancer = Balancer(inp.balance, *self.commands.shape)
            self.planned, self.commands = self.commands, self.commands.copy()
        self.dt = float(m.opt.timestep)
        law, first, av = inp.law, self.commands[0], inp.sim.actuated_dof
        self.servo: ServoLoop = (
            PartLoop(law, self.dt, first, m, d, av)
            if isinstance(law, PartLaw)
            else ServoLoop(law, self.dt, first)
        )
        self.setpoints = Setpoints(law, self.dt, first)
        aq = inp.sim.actuated_qpos
        # Contiguous actuated coordinates are read and written through views (no copies).
        self._qpos = d.qpos[aq[0] : aq[-1] + 1] if contiguous(aq) else None
        self._qfrc = d.qfrc_applied[av[0] : av[-1] + 1] if contiguous(av) else None
        self._aq, self._av = aq, av
        self._ctrl, self._opt = d.ctrl, m.opt
        flags = int(m.opt.disableflags)
        # The recording's sensors run only in a sample's forward pass, not in the steps.
        self._flags_sample = flags & ~int(mujoco.mjtDisableBit.mjDSBL_SENSOR)
        self._flags_steps = flags | int(mujoco.mjtDisableBit.mjDSBL_SENSOR)
        m.opt.disableflags = self._flags_steps
        self._blocks: Blocks | None = None  # the ideal servo's: made after the settling
        if self.in_mujoco and isinstance(self.servo, PartLoop):
            self._blocks = self._new_blocks()  # the parts' settle in it

    def settle(self) -> None:
        """Hold the first command for `settle_s` (not recorded); the balance feedback
        corrects it every `ticks` steps."""
        command = self.commands[0]
        settle = round(self.inp.settle_s / self.dt)
        spans = [settle] if self.balancer is None else split_spans(settle, self.ticks)
        for span in spans:
            if self.balancer is not None:
                command = self.balancer.command(0, self.d.qpos, self.d.qvel, self.planned[0], False)
            if isinstance(self._blocks, PartBlocks):
                self._blocks.hold(command, span)
            elif self.in_mujoco:
                rows = self.setpoints.hold(command, span)
                self._ctrl_steps(rows, command, 0, span)
            else:
                self.servo.set_command(command)
                for _ in range(span):
                    self._apply_torque()
                    self._mj.mj_step(self.m, self.d)
        if isinstance(self.servo, PartLoop):
            self.servo.reset_energy()

    def block(self, k0: int, k1: int, recorder: Recorder) -> None:
        """Record samples [k0, k1), each then holding its command for `ticks` steps (ramped
        to the next one with `linear_hold`), but the motion's last (record only)."""
        if self.balancer is not None and k1 - k0 > 1:
            for k in range(k0, k1):
                self.block(k, k + 1, recorder)
            return
        if self.balancer is not None:  # the feedback reads the torso before sample k0 goes
            self.commands[k0] = self.balancer.command(
                k0, self.d.qpos, self.d.qvel, self.planned[k0]
            )
            self.setpoints.changed(self.commands, k0)
        if self.in_mujoco:
            if self._blocks is None:  # after the settling: its last torque is the first's
                self._blocks = self._new_blocks()
            self._blocks.run(k0, k1, recorder)
        else:
            for k in range(k0, k1):
                self._python_sample(k, recorder, last=k == len(self.commands) - 1)
        recorder.derive(k0, k1)

    def _new_blocks(self) -> Blocks:
        """The block stepper of the law in MuJoCo (servo parts': `part_blocks`)."""
        sim = self.inp.sim
        args = (self.m, self.d, self.ctrl_joint, self.ticks, self.setpoints, self.commands)
        actuated = (sim.actuated_qpos, sim.actuated_dof)
        if isinstance(self.servo, PartLoop):
            return PartBlocks(*args, actuated, self.inp.linear_hold, self.servo)
        return Blocks(*args, actuated, self.inp.linear_hold)

    def _python_sample(self, k: int, recorder: Recorder, last: bool) -> None:
        """Sample k with the law in Python: the forward pass sees the torque the law left in
        qfrc_applied, then `ticks` steps with the law at every one."""
        mj, m, d, ticks, commands = self._mj, self.m, self.d, self.ticks, self.commands
        opt = self._opt
        opt.disableflags, tolerance, opt.tolerance = (
            self._flags_sample,
            opt.tolerance,
            FORWARD_TOLERANCE,
        )
        mj.mj_forward(m, d)
        opt.disableflags, opt.tolerance = self._flags_steps, tolerance
        recorder.record(k)
        if last:
            return
        command, after = commands[k], commands[min(k + 1, len(commands) - 1)]
        step = (after - command) / ticks if self.inp.linear_hold else None
        if step is None:
            self.servo.set_command(command)
        for i in range(1, ticks + 1):
            if step is not None:
                self.servo.set_command(command + i * step)
            self._apply_torque()
            mj.mj_step(m, d)
        recorder.tau[k] = self.servo.tau

    def _ctrl_steps(self, rows: np.ndarray | None, command: np.ndarray, first: int, ticks: int):
        """Steps `first` … `ticks` − 1 of a hold at the set points `rows` (None: `command`):
        one step per row while the set point moves (`Setpoints.moving`), then one
        `mj_step(n)` at the command."""
        mj, m, d, ctrl = self._mj, self.m, self.d, self._ctrl
        moving = 0 if rows is None else self.setpoints.moving
        if moving > first:
            assert rows is not None
            for row in rows[first:moving, self.ctrl_joint]:
                ctrl[:] = row
                mj.mj_step(m, d)
        rest = ticks - max(first, moving)
        if rest > 0:
            ctrl[:] = command[self.ctrl_joint]
            mj.mj_step(m, d, rest)

    def _apply_torque(self) -> None:
        """The Python law's torque at the current joint angles into qfrc_applied."""
        d = self.d
        tau = self.servo.torque(d.qpos[self._aq] if self._qpos is None else self._qpos)
        if self._qfrc is None:
            d.qfrc_applied[self._av] = tau
        else:
            self._qfrc[:] = tau


def split_spans(ticks: int, every: int) -> list[int]:
    """`ticks` steps cut into spans of `every` (the last one shorter)."""
    return [min(every, ticks - start) for start in range(0, ticks, every)]


def contiguous(indices: np.ndarray) -> bool:
    return len(indices) > 0 and bool(np.all(np.diff(indices) == 1))
