"""01 — Load a robot and check it.

A robot is a URDF: a built-in name ("servo_biped", "dircon_biped", "hybrid_leg_biped") or a
path to a .urdf file. `load_robot` parses it into a `RobotModel` (pinocchio model, feet,
legs, actuated joints); `robot_report` lists what a designer should look at (masses,
inertias, limits, feet) and any problem found.

    .venv/bin/python examples/01_load_and_check.py [ROBOT_OR_URDF]
"""

import sys

from app.core.robot.loading import load_robot
from app.core.robot.report import robot_report

source = sys.argv[1] if len(sys.argv) > 1 else "servo_biped"

# Built-in name or path; a bad file raises a RobotLoadError whose message says what to fix.
robot = load_robot(source)
print(f"{robot.name}: {robot.n_actuated} actuated joints, {robot.mass_kg:.3f} kg")
print("feet:", ", ".join(f"{foot.side} = {foot.link}" for foot in robot.feet))

# The same report `biped-studio check ROBOT` prints.
report = robot_report(robot)
for line in report.lines():
    print(line)
