"""The clickable Pareto board in the 3D view: each point where its metrics put it on the upright
board (failed ones in the strip under the axis) and the camera view that shows the whole board
(tests/browser/test_sweep_browser.py clicks a point of it in Chromium)."""

from __future__ import annotations

import math

import numpy as np
import viser

from app.core.sweeps.plot_points import PlotPoints
from app.views.pareto_board import ParetoBoard
from tests.studio.conftest import free_port


def test_points_stand_where_their_metrics_say_on_a_board_the_camera_sees_whole():
    server = viser.ViserServer(host="127.0.0.1", port=free_port(), verbose=False)
    try:
        board = ParetoBoard(server, "/test_board", lambda _index, _client: None)
        toward = np.array([1.0, 0.0, 0.0])  # the viewer stands on +x
        board.place(np.array([0.0, 0.0, 0.1]), toward, 0.6)
        points = PlotPoints(
            labels=("sr", "max_torque_Nm"),
            index=(4, 7, 9, 2),
            xy=np.array([[0.1, 5.0], [0.3, 2.0], [0.2, 9.0], [0.2, -1.0]]),
            kind=("front", "front", "design", "failed"),
            fell=np.zeros(4, dtype=bool),
            strip_y=-1.0,
        )
        board.draw(points, selected=7)
        at = {i: board.world_position(i) for i in (4, 7, 9, 2)}
        assert board.world_position(5) is None
        # upright, facing +x: x is the depth
        depths = [p[0] for p in at.values()]
        assert max(depths) - min(depths) < 1e-9 and depths[0] > 0.0  # in front of the board
        # a viewer on +x looking back along −x with z up has +y on the right: larger sr there
        assert at[4][1] < at[9][1] < at[7][1]
        assert at[7][2] < at[4][2] < at[9][2]  # larger torque higher
        assert at[2][2] < at[7][2] and 0.1 < at[2][2] < 0.1 + 0.6  # the strip: lowest
        # the solved points' ranges span the board's plotting area
        width, height = board.size_m
        assert math.isclose(at[7][1] - at[4][1], (0.95 - 0.14) * width, rel_tol=1e-9)

        # the camera view looks at the board head on and holds all of it
        eye, look_at = board.view(math.radians(50.0), 1.6)
        assert eye[0] > look_at[0] and math.isclose(eye[2], look_at[2])
        half_height = (eye[0] - look_at[0]) * math.tan(math.radians(25.0))
        assert half_height >= 0.5 * height
    finally:
        server.stop()
