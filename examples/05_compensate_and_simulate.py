"""05 — Compensate the servos' springiness and check it in simulation.

A hobby servo under load τ sags by k·τ (k in °/(N·m)). The compensation paper sends
q_cmd = q + k·τ instead of q (eq 7), plus φ·sign(…) for the dead band (eq 23). Here the
torques come from the whole-body QP (example 04), the coefficients from a preset, and MuJoCo
runs the motion on compliant servos with dead bands, once as planned and once compensated.

    .venv/bin/python examples/05_compensate_and_simulate.py
"""

import numpy as np

from app.core.dynamics.wbc import torque_feedforward
from app.core.motions.library import run_motion
from app.core.robot.loading import load_robot
from app.core.servo.commands import servo_commands
from app.core.servo.presets import PRESETS, preset_params
from app.core.simulation.files import default_servos
from app.core.simulation.run import simulate_commands

robot = load_robot("servo_biped")
traj = run_motion(robot, "one_leg_stand", dt=0.02, speed=2.0).trajectory
ff = torque_feedforward(robot, traj)

for key, preset in PRESETS.items():
    print(f"preset {key:17s} {preset.label}")
params = preset_params("uniform", robot)  # the same k on every leg joint, no φ
commands = servo_commands(robot, traj, ff.tau_Nm, params, ff.status)
correction_deg = np.degrees(np.abs(commands.q_cmd_rad - commands.q_plan_rad)).max(axis=0)
for name, k, c in zip(robot.joint_names, params.k_deg_per_Nm, correction_deg, strict=True):
    if c > 0.5:
        print(f"  {name:18s} k {k:.2f} °/(N·m): commands up to {c:.2f}° past the plan")
for warning in commands.warnings:  # e.g. a command beyond a joint limit
    print("warning:", warning)

# The "real" servos of the simulation: 1.4 °/(N·m) and a 0.5° dead band on the legs.
servo = default_servos(robot)
runs = simulate_commands(
    robot,
    traj,
    {"as planned": commands.q_plan_rad, "compensated": commands.q_cmd_rad},
    servo,
)
for label, run in runs.items():
    s = run.summary()
    print(
        f"{label:12s} {run.verdict()}: max |roll| {s['max_abs_roll_deg']:.2f}°, "
        f"rms joint error {s['rms_joint_error_deg']:.2f}°"
    )
