"""The one click (Plan → walk → torques → simulate) from the Gait panel: its stages are shown
under the button while they run, and afterwards every ghost stands on the robot (issue 23,
defect 10: the simulated ghosts stood ~10 cm beside it); the quick estimate and the simulation
each give their torso-error figure under their own heading (defect 4)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from app.core.quaternions import wxyz_to_matrix
from app.core.servo.model import stance_is_right
from tests.studio.conftest import wait_for_signal

MM = 1e-3


def link_origins(ghosts, name: str, link: str) -> np.ndarray:
    """World position of `link`'s origin in ghost `name` as drawn: from the first mesh of the
    link, or of its nearest ancestor with a mesh (a sole frame has none)."""
    robot = ghosts.robot
    meshes = [mesh for mesh in robot.meshes if mesh.role != "collision"]
    placements = robot.link_placements(robot.q_neutral, robot.model.createData())
    carrier = link
    while not any(mesh.link == carrier for mesh in meshes):
        carrier = robot.tree.parent_joint(carrier).parent
    T_carrier_link = np.linalg.inv(placements[carrier]) @ placements[link]  # fixed joints
    i = next(i for i, mesh in enumerate(meshes) if mesh.link == carrier)
    positions, wxyzs = ghosts.mesh_poses(name)
    T_world_mesh = np.eye(4)
    T_world_mesh[:3, :3] = wxyz_to_matrix(wxyzs[i])
    T_world_mesh[:3, 3] = positions[i]
    return (T_world_mesh @ np.linalg.inv(meshes[i].T_link_mesh) @ T_carrier_link)[:3, 3]


def test_one_click_shows_its_stages_then_ghosts_stand_on_the_robot(studio):
    gait, simulation, state = studio.gait, studio.servo_rooms.simulation, studio.state
    seen: list[tuple[str, str, bool]] = []

    def record(stage: str) -> None:
        # what the line says, and whether the stage it names is really under way
        really = {
            "planning": lambda: gait.solves.running is not None,
            "torques": lambda: (
                state.work.torques is None
                and gait.walk is not None
                and studio.state.trajectory is gait.walk.trajectory
            ),
            "simulating": lambda: simulation.runner.running is not None,
            "done": lambda: state.work.simulation is not None,
        }.get(stage, lambda: False)()
        if not seen or seen[-1][0] != stage:
            seen.append((stage, studio.pipeline.line.content, really))

    studio.pipeline.shown.connect(record)
    simulated = wait_for_signal(
        simulation.runner.finished, lambda: setattr(gait.panel.all_stages, "value", True)
    )
    assert simulated.error == ""
    assert [stage for stage, _, _ in seen] == ["planning", "torques", "simulating", "done"]
    for stage, content, really in seen:
        assert really, f"the line said {stage!r} when that stage was not running"
        if stage != "done":
            assert f"⏳ **{stage}**" in content and "since the click" in content
    assert "✅ planning → ✅ walking → ⏳ **torques**" in seen[1][1]

    # Every ghost drawn on the robot: the plan exactly, the others on the plan's stance foot.
    studio.playback.player.pause()
    for box in studio.servo_rooms.ghosts.panel.ghosts.values():
        box.value = True
    robot, trajectory = studio.state.robot, studio.state.trajectory
    ghosts = studio.servo_rooms.ghosts.view
    data = robot.model.createData()
    right = stance_is_right(trajectory.contacts)
    for fraction in (0.0, 0.3, 0.55, 0.8, 1.0):
        studio.playback.seek(fraction * trajectory.duration)
        k = trajectory.index_at(studio.state.time_s)
        np.testing.assert_array_equal(studio.state.pose.q, trajectory.q[k])  # the robot
        placements = robot.link_placements(trajectory.q[k], data)
        for link in robot.link_frame_ids:
            if any(m.link == link and m.role != "collision" for m in robot.meshes):
                drawn = link_origins(ghosts, "planned", link)
                assert np.linalg.norm(drawn - placements[link][:3, 3]) < MM, link
        foot = robot.feet[int(right[k])].link
        pin.framesForwardKinematics(robot.model, data, trajectory.q[k])
        planned_foot = data.oMf[robot.link_frame_ids[foot]].translation
        for name in ghosts.names:
            assert ghosts.shown(name), name
            offset = link_origins(ghosts, name, foot)[:2] - planned_foot[:2]
            assert np.linalg.norm(offset) < MM, (name, fraction, offset)

    # One figure per heading: the quick estimate in Plots, the simulation in its verdict.
    quick, verdict = studio.servo_rooms.ghosts.plots.info.content, simulation.panel.verdict.content
    assert "Quick estimate" in quick and "imulat" not in quick
    assert "Simulated** (MuJoCo)" in verdict and "quick estimate" not in verdict.lower()
    for label, run in simulated.results.items():
        roll = np.degrees(np.max(np.abs(run.roll_rad - run.roll_planned_rad)))
        assert f"{label}: **{run.verdict()}**; simulated largest torso error roll {roll:.2f}°" in (
            verdict
        )
    errors = state.work.prediction.attitude_errors_deg()
    assert f"quick estimate, compensated: roll {errors['roll_compensated']:.2f}°" in quick


def test_one_click_says_where_it_stopped_when_the_simulation_cannot_start(studio, monkeypatch):
    """A simulation that refuses its inputs (here made to: commands past a joint limit no
    longer do, they are clipped to it) stops the one click's line there with why, not
    "⏳ simulating" for ever."""
    import app.studio.simulation_runner as runner_module
    from app.core.simulation.errors import SimulationInputError

    why = "the simulation refuses these runs"

    def refuse(*_args, **_kwargs):
        raise SimulationInputError(why)

    monkeypatch.setattr(runner_module, "simulation_job", refuse)
    gait = studio.gait
    stopped = wait_for_signal(
        studio.pipeline.shown,
        lambda: setattr(gait.panel.all_stages, "value", True),
        accept=lambda stage: stage in ("stopped", "done"),
    )
    assert stopped == "stopped"
    line = studio.pipeline.line.content
    assert "stopped at simulating" in line and why in line
    assert studio.servo_rooms.simulation.runner.running is None
