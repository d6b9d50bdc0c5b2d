"""Physics simulation of a motion on the robot's servos (MuJoCo), with a fall verdict.

mjcf: the robot as MJCF, from its pinocchio model. servo_law: the position servo's equations.
engine: the step loop (numpy and mujoco only, runs in worker processes). run: checked inputs in,
`SimulationResult` (result) out. files: servo.toml, command CSV in, simulation CSV out.
worker: jobs for the studio's SolverWorker. experiments: the paper's section 5 experiments.
Its speed against the targets: app/bench/simulation.py.
"""
