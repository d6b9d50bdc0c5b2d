"""Physics simulation of a motion on the robot's servos (MuJoCo), with a verdict.

mjcf: the robot as MJCF, from its pinocchio model. servo_law: the position servo's equations.
engine: the step loop (numpy and mujoco only, runs in worker processes). run: checked inputs in,
`SimulationResult` (result) out, judged by verdicts (stays up / leans on the lifted foot /
slips / falls; distance and footsteps of a motion that travels). files: servo.toml, command
CSV in, simulation CSV out.
worker: jobs for the studio's SolverWorker. experiments: the paper's section 5 experiments.
Its speed against the targets: app/bench/simulation.py.
"""
