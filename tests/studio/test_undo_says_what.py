"""*Undo* and *Redo* say what they undid or redid, in the Project panel's status and in a
notification to the tab that clicked: the joint the user moved and by how much, the foot that
was dragged, the keyframe that was captured; "Nothing to undo" when the history is empty."""

from __future__ import annotations

import numpy as np

from tests.studio.conftest import wait_for_signal


def _said(studio) -> tuple[str, str]:
    last = studio.notifier.last  # what the tab was told
    assert last is not None
    return studio.project.panel.status.content, last.title


def test_undo_and_redo_name_the_edit(studio):
    project, state = studio.project, studio.state
    robot = state.robot
    assert not project.undo()
    assert _said(studio) == ("Nothing to undo", "Nothing to undo")

    # A joint slider moved by 10°: Undo names that joint and the change, measured on the state.
    name, slider = next(iter(studio.joints.panel.sliders.items()))
    joint = robot.joint_names.index(name)
    q0 = state.q.copy()
    wait_for_signal(project.autosave.written, lambda: setattr(slider, "value", slider.value + 10.0))
    moved_deg = np.rad2deg(robot.joint_angles(state.q)[joint] - robot.joint_angles(q0)[joint])
    assert abs(moved_deg - 10.0) < 0.1  # within its limits: the slider moved it by 10°
    others = np.delete(robot.joint_angles(state.q) - robot.joint_angles(q0), joint)
    assert np.abs(others).max() < 1e-9  # that joint alone

    # A keyframe captured.
    wait_for_signal(project.autosave.written, lambda: studio.motions.capture(0.8))
    captured = studio.motions.keyframes[0].name

    # The left foot dragged 2 cm up.
    foot = robot.feet[0].link
    target = robot.link_placements(state.q, robot.model.createData())[foot].copy()
    target[2, 3] += 0.02
    wait_for_signal(project.autosave.written, lambda: studio.pose.request_drag("left", target))

    assert project.undo()
    assert _said(studio) == ("Undid: left foot drag", "Undid: left foot drag")
    assert project.undo()
    assert _said(studio)[0] == f"Undid: keyframe “{captured}” added"
    assert studio.motions.keyframes == []
    assert project.undo()
    assert _said(studio)[0] == f"Undid: joint {name} {moved_deg:+.1f}°"
    assert np.array_equal(state.q, q0)
    assert not project.undo()
    assert _said(studio)[0] == "Nothing to undo"

    assert project.redo()
    assert _said(studio)[0] == f"Redid: joint {name} {moved_deg:+.1f}°"
    assert project.redo()
    assert _said(studio)[0] == f"Redid: keyframe “{captured}” added"
    # Undo after a redo still names the edit (not the "button" that put the step back).
    assert project.undo()
    assert _said(studio)[0] == f"Undid: keyframe “{captured}” added"


def test_a_slow_drag_is_one_undo_step(studio):
    """A drag whose events come slower than the autosave's quiet period (a busy machine, a
    hesitating hand) is still one step: none is taken while the handle is held."""
    project, state = studio.project, studio.state
    robot = state.robot
    data = robot.model.createData()
    foot = robot.feet[0].link
    q0 = state.q.copy()
    handles = studio.pose.handles
    handles.held.add("left")  # a tab grabbed the left foot's handle
    start = robot.link_placements(state.q, data)[foot].copy()
    for k in range(1, 4):  # three moves, each followed by a still moment
        target = start.copy()
        target[2, 3] += 0.01 * k
        wait_for_signal(
            project.autosave.written, lambda t=target: studio.pose.request_drag("left", t)
        )
    handles.held.discard("left")  # released
    target = start.copy()
    target[2, 3] += 0.03
    wait_for_signal(project.autosave.written, lambda: studio.pose.request_drag("left", target))

    assert project.undo()
    assert _said(studio)[0] == "Undid: left foot drag"
    assert np.array_equal(state.q, q0)  # the whole drag, in one step
