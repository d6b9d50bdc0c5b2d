"""The Compare folder from Python handles (the browser test clicks it): *Plan vs* picks the
one ghost drawn beside the plan, *Colour by error* colours that ghost's links by their distance
from the plan's (checked against pinocchio)."""

from __future__ import annotations

import numpy as np
import pytest

from app.views.ghosts_view import ERROR_FULL_SCALE_M, GHOSTS
from tests.studio.conftest import with_stand_torques


@pytest.fixture
def studio(studio):
    """The conftest's studio with the one-leg stand and its torques (each test its own)."""
    return with_stand_torques(studio)


def test_colour_by_error_follows_the_links_distance_from_the_plan(studio):
    session = studio.servo_rooms.ghosts
    panel, ghosts = session.compare.panel, session.view
    panel.choice.value = GHOSTS["without"][1]
    shown = {name for name, box in session.panel.ghosts.items() if box.value}
    assert shown == {"planned", "without"}
    trajectory = studio.state.trajectory
    single = np.flatnonzero(trajectory.contacts[:, 0] != trajectory.contacts[:, 1])
    studio.playback.seek(float(trajectory.t[single[len(single) // 2]]))
    k = trajectory.index_at(studio.state.time_s)
    own = np.array(GHOSTS["without"][0])
    assert np.all(ghosts.colours("without") == own)

    panel.errors.value = True
    robot = studio.state.robot
    data = robot.model.createData()
    planned = robot.link_placements(trajectory.q[k], data)
    estimate = robot.link_placements(studio.state.work.prediction.q_world_uncompensated[k], data)
    errors = np.array(
        [np.linalg.norm(estimate[link][:3, 3] - planned[link][:3, 3]) for link in ghosts.mesh_links]
    )
    assert errors.max() > 0.2 * ERROR_FULL_SCALE_M, "the estimate hardly differs from the plan"
    colours = ghosts.colours("without").astype(int)
    order = np.argsort(errors)
    # farther from the plan: redder and less green
    assert np.all(np.diff(colours[order, 0]) >= 0) and np.all(np.diff(colours[order, 1]) <= 0)
    foot = robot.feet[0].link  # the stance foot stands on the plan's
    on_foot = [i for i, link in enumerate(ghosts.mesh_links) if link == foot or errors[i] < 1e-4]
    assert on_foot and np.all(colours[on_foot, 0] <= 2) and np.all(colours[on_foot, 1] >= 253)
    assert np.all(ghosts.colours("planned") == np.array(GHOSTS["planned"][0]))

    # Another comparison takes the colouring; unticking gives the ghosts their own colours.
    panel.choice.value = GHOSTS["with"][1]
    assert ghosts.error_ghost == "with" and np.all(ghosts.colours("without") == own)
    panel.errors.value = False
    assert ghosts.error_ghost is None
    assert np.all(ghosts.colours("with") == np.array(GHOSTS["with"][0]))
