"""The torques' summary line of the Compensation folder: the peak |τ| over the samples the
robot can follow, and the samples it cannot (the torques session writes it when τ arrives; the
compensation session writes it back when one of its warnings no longer holds)."""

from __future__ import annotations

import numpy as np

from app.core.dynamics.peaks import TorquePeaks
from app.core.motions.trajectory import Trajectory


def torque_summary(peaks: TorquePeaks, trajectory: Trajectory) -> str:
    """Peak torque over the samples the QP and the joints' speed limits can follow; flagged
    samples named apart (their torques are not peaks: the robot cannot do them)."""
    worst = int(np.argmax(peaks.max_abs_tau_Nm)) if len(peaks.joint_names) else 0
    lines = [
        f"τ of **{trajectory.name}**: max |τ| {peaks.max_abs_tau_Nm[worst]:.2f} N·m "
        f"({peaks.joint_names[worst]}) over the samples the robot can follow."
    ]
    for what, samples in (
        ("the whole-body QP cannot follow", peaks.infeasible_samples),
        ("ask a joint to move faster than its limit", peaks.over_speed_samples),
    ):
        if samples:
            first = trajectory.t[samples[0]]
            lines.append(
                f"⚠️ **{len(samples)} sample(s) {what}** (first at t = {first:.2f} s); their "
                "torques are left out of the peak."
            )
    if peaks.flagged_samples:
        everything = float(np.max(peaks.max_abs_tau_all_samples_Nm))
        lines.append(f"Peak over every sample, flagged ones included: {everything:.2f} N·m.")
    return "  \n".join(lines)
