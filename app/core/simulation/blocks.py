"""The ideal servo's samples a block at a time in C (numpy and mujoco only).

With the servo law in MuJoCo's actuators (`servo_law.actuators_xml`) nothing between two
samples needs Python:

1. the block's set points are computed ahead (`Setpoints`: they depend on the commands
   alone), and one `mujoco.rollout` call steps every physics tick of the block from the
   live MjData (the same `mj_step`s in the same order as a loop of them), returning each
   tick's state;
2. the torque of each hold's last step (the run's τ after the sample, and what the servo
   applies as the next sample is taken) is the actuators' law on that step's state and set
   point, as MuJoCo computes it (gain·ctrl + b₀ + b₁·q clamped to the force range, summed
   per joint);
3. the samples' rows (`recording`) come from one batched forward pass over the block's
   sample states: a second `rollout` of one step per sample with the actuators off and the
   torque of the step before the sample as `qfrc_applied`, whose sensor rows are the
   recording's (`recording.sensors_xml`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from app.core.simulation.recording import FORWARD_TOLERANCE, Recorder
from app.core.simulation.servo_law import Setpoints


class Blocks:
    """The physics of a run whose servos are MuJoCo actuators, a block of samples per call
    (module docstring). `torque_before`: the generalised torque (nv,) of the step before the
    next sample (after the settling, the live MjData's)."""

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
    ) -> None:
        import mujoco
        from mujoco import rollout

        self.m, self.d, self.ctrl_joint, self.ticks = m, d, ctrl_joint, ticks
        self.setpoints, self.commands, self.linear_hold = setpoints, commands, linear_hold
        self._mj, self._rollout = mujoco, rollout.rollout
        self._kind = int(mujoco.mjtState.mjSTATE_FULLPHYSICS)
        self._qfrc_spec = int(mujoco.mjtState.mjSTATE_QFRC_APPLIED)
        self._nstate = mujoco.mj_stateSize(m, self._kind)
        self._check = mujoco.MjData(m)  # the batched forward pass's and the contact scans'
        flags = int(m.opt.disableflags)
        sensors, actuation = (
            mujoco.mjtDisableBit.mjDSBL_SENSOR,
            mujoco.mjtDisableBit.mjDSBL_ACTUATION,
        )
        self._flags_steps = flags | int(sensors)
        self._flags_forward = (flags & ~int(sensors)) | int(actuation)
        actuated_qpos, self._actuated_dof = actuated
        self._act_qpos = actuated_qpos[ctrl_joint]
        self._gain = m.actuator_gainprm[:, 0].copy()
        self._bias0, self._bias1 = m.actuator_biasprm[:, 0].copy(), m.actuator_biasprm[:, 1].copy()
        self._lo, self._hi = m.actuator_forcerange[:, 0].copy(), m.actuator_forcerange[:, 1].copy()
        # Each joint's actuators are consecutive (`actuators_xml`): a sum per run of them.
        self._first_actuator = np.flatnonzero(np.diff(ctrl_joint, prepend=-1))
        self.torque_before = d.qfrc_actuator.copy()

    def run(self, k0: int, k1: int, recorder: Recorder) -> None:
        """Record samples [k0, k1) and hold each one's command but the motion's last (module
        docstring); the live MjData ends at sample k1's state."""
        holds = min(k1, len(self.commands) - 1) - k0
        state0 = self.state()
        states = tau = None
        if holds > 0:
            control = self._controls(k0, k0 + holds)
            states = self._steps(state0, control)
            ticks, nq = self.ticks, self.m.nq
            # Each hold's last step starts from the state one tick before its end.
            before = states[ticks - 2 :: ticks] if ticks > 1 else self._starts(state0, states)
            tau = self._law(before[:, 1 : 1 + nq], control[ticks - 1 :: ticks])
        self._record(k0, k1, state0, states, tau, recorder)

    def state(self) -> np.ndarray:
        """The live MjData's full physics state (`mjSTATE_FULLPHYSICS`)."""
        state = np.empty(self._nstate)
        self._mj.mj_getState(self.m, self.d, state, self._kind)
        return state

    def _steps(self, state0: np.ndarray, control: np.ndarray) -> np.ndarray:
        """One `mujoco.rollout` of a step per row of `control` (ctrl) from the live MjData
        at `state0`, warm-started as it is: the state after each step (rows, nstate); the
        live MjData ends at the last."""
        states = np.empty((1, len(control), self._nstate))
        self.m.opt.disableflags = self._flags_steps
        self._rollout(
            [self.m],
            [self.d],
            state0[None],
            control[None],
            skip_checks=True,
            nstep=len(control),
            initial_warmstart=self.d.qacc_warmstart.copy()[None],
            state=states,
        )
        return states[0]

    @staticmethod
    def _starts(state0: np.ndarray, states: np.ndarray) -> np.ndarray:
        """The state each step of `_steps` starts from: `state0`, then each row but the last."""
        return np.concatenate([state0[None], states[:-1]])

    def _record(
        self,
        k0: int,
        k1: int,
        state0: np.ndarray,
        states: np.ndarray | None,
        tau: np.ndarray | None,
        recorder: Recorder,
    ) -> None:
        """The rows of samples [k0, k1) from the holds' states (`_steps`, None without a hold)
        and each hold's last torque `tau` (holds, n): sample k0 at `state0`, each later one at
        the end of the hold before it (module docstring, 2 and 3)."""
        mj, m, ticks, nq, nv = self._mj, self.m, self.ticks, self.m.nq, self.m.nv
        holds = 0 if tau is None else len(tau)
        samples = np.empty((k1 - k0, self._nstate))
        samples[0] = state0
        if states is not None:
            samples[1:] = states[ticks - 1 :: ticks][: k1 - k0 - 1]  # the state after each hold
        applied = np.zeros((k1 - k0, 1, nv))
        applied[0, 0] = self.torque_before
        if tau is not None and holds > 0:
            applied[1 : holds + 1, 0, self._actuated_dof] = tau[: k1 - k0 - 1]
            self.torque_before = np.zeros(nv)
            self.torque_before[self._actuated_dof] = tau[-1]
            recorder.tau[k0 : k0 + holds] = tau
        self._forward(samples, applied, recorder.sensed[k0:k1])
        recorder.time[k0:k1] = samples[:, 0]
        recorder.qpos[k0:k1] = samples[:, 1 : 1 + nq]
        recorder.qvel[k0:k1] = samples[:, 1 + nq : 1 + nq + nv]
        for k in recorder.off_feet(k0, k1).tolist():
            mj.mj_setState(m, self._check, samples[k - k0], self._kind)
            mj.mj_forward(m, self._check)
            recorder.touched_body[k] = recorder.first_non_foot_body(self._check)
        m.opt.disableflags = self._flags_steps

    def _controls(self, k0: int, k1: int) -> np.ndarray:
        """Every physics tick's ctrl for the holds of samples [k0, k1) (`Setpoints`)."""
        commands, ticks, setpoints = self.commands, self.ticks, self.setpoints
        rows = np.empty((k1 - k0, ticks, commands.shape[1]))
        held: np.ndarray | None
        for k in range(k0, k1):
            if self.linear_hold:
                held = setpoints.ramp(commands[k], commands[min(k + 1, len(commands) - 1)], ticks)
            else:
                held = setpoints.hold_sample(commands, k, ticks)
            rows[k - k0] = commands[k] if held is None else held
        return np.ascontiguousarray(rows.reshape(-1, commands.shape[1])[:, self.ctrl_joint])

    def _law(self, qpos: np.ndarray, ctrl: np.ndarray) -> np.ndarray:
        """The actuators' torque on each actuated joint (rows, n) [N·m] at joint positions
        `qpos` (rows, nq) and set points `ctrl` (rows, nu), MuJoCo's `general` actuator
        with affine bias: clamp(gain·ctrl + b₀ + b₁·q, force range)."""
        force = self._gain * ctrl + (self._bias0 + self._bias1 * qpos[:, self._act_qpos])
        force = np.minimum(np.maximum(force, self._lo), self._hi)
        return np.add.reduceat(force, self._first_actuator, axis=1)

    def _forward(self, samples: np.ndarray, applied: np.ndarray, sensed: np.ndarray) -> None:
        """The recording's sensors at each sample state (rows of `sensed`), actuators off and
        `applied` (rows, 1, nv) as qfrc_applied: one rollout step per sample (module
        docstring, 3)."""
        m, n = self.m, len(samples)
        m.opt.disableflags = self._flags_forward
        tolerance = m.opt.tolerance
        m.opt.tolerance = FORWARD_TOLERANCE
        self._rollout(
            [m] * n,
            [self._check],
            samples,
            applied,
            control_spec=self._qfrc_spec,
            skip_checks=True,
            nstep=1,
            state=np.empty((n, 1, self._nstate)),
            sensordata=sensed.reshape(n, 1, -1),
        )
        m.opt.tolerance = tolerance
