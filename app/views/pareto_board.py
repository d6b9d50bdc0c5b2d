"""A sweep's Pareto plot drawn in the 3D view as a board of clickable points.

viser's GUI plots (uPlot, Plotly) report no clicks to the server, but scene nodes do, and a
batched mesh says which of its instances was clicked. So the board draws the points as two
batched meshes (round markers for solved points, crosses for failed ones in a strip below the
axis) and hands the clicked point's index to `on_pick`. Everything hangs under one root node,
a frame standing upright beside the robot and facing the studio's first camera.

Board frame: x to the right along the plot's x axis, z up along its y axis, y into the board;
the plot spans [0, width] × [0, height] in x and z [m].
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, Literal

import numpy as np
import trimesh
import viser

from app.core.quaternions import matrix_to_wxyz
from app.core.sweeps.plot_points import PlotPoints
from app.views.roots import AlternatingRoot

COLOURS = {
    "design": (76, 114, 176),
    "front": (214, 39, 40),
    "fell": (31, 31, 31),
    "failed": (150, 150, 150),
}
"""Marker colours by kind (the panel's plot uses the same)."""
SELECTED_COLOUR = (255, 190, 0)
U_RANGE = (0.14, 0.95)
"""Where the solved points' x range lies across the board (fractions of its width)."""
V_RANGE = (0.28, 0.88)
"""Where their y range lies up the board (fractions of its height)."""
V_STRIP = 0.09
"""The failed strip's height on the board (fraction)."""
V_AXIS = 0.18
MARKER = 0.022
"""Marker radius, × the board's height."""
Anchor = Literal[
    "top-center", "bottom-right", "bottom-left", "bottom-center", "center-left", "center-right"
]
Pick = Callable[[int, Any], None]
"""Called with (point index, the clicking client)."""


def _sphere() -> tuple[np.ndarray, np.ndarray]:
    mesh = trimesh.creation.icosphere(subdivisions=1, radius=1.0)
    return np.asarray(mesh.vertices, np.float32), np.asarray(mesh.faces, np.uint32)


def _cross() -> tuple[np.ndarray, np.ndarray]:
    """Two bars crossed at ±45° in the board's x-z plane, 2 across."""
    bars = []
    for angle in (math.pi / 4, -math.pi / 4):
        bar = trimesh.creation.box(extents=(2.6, 0.3, 0.55))
        bar.apply_transform(trimesh.transformations.rotation_matrix(angle, (0, 1, 0)))
        bars.append(bar)
    mesh = trimesh.Trimesh(
        np.concatenate([bars[0].vertices, bars[1].vertices]),
        np.concatenate([bars[0].faces, bars[1].faces + len(bars[0].vertices)]),
    )
    return np.asarray(mesh.vertices, np.float32), np.asarray(mesh.faces, np.uint32)


def board_frame(toward_viewer: np.ndarray) -> np.ndarray:
    """The board's rotation (world from board) for a board facing horizontal direction
    `toward_viewer`: columns x right (as the viewer sees it), y into the board, z up."""
    d = np.array([toward_viewer[0], toward_viewer[1], 0.0], dtype=float)
    d /= np.linalg.norm(d)
    right = np.array([-d[1], d[0], 0.0])
    return np.column_stack([right, -d, [0.0, 0.0, 1.0]])


class ParetoBoard:
    """The clickable Pareto plot in the scene, under `root` (which it owns)."""

    def __init__(self, server: viser.ViserServer, root: str, on_pick: Pick) -> None:
        self._server = server
        self._roots = AlternatingRoot(root)
        self._on_pick = on_pick
        self._nodes: list[Any] = []
        self._highlight: Any = None
        self._local: dict[int, np.ndarray] = {}
        """Board-frame position of each drawn point [m]."""
        self.origin = np.zeros(3)
        self.rotation = np.eye(3)
        self.size_m = (1.0, 0.75)
        self.visible = True

    def place(self, origin_m: np.ndarray, toward_viewer: np.ndarray, height_m: float) -> None:
        """Stand the board with its lower left corner at `origin_m`, facing `toward_viewer`;
        takes effect at the next `draw`."""
        self.origin = np.asarray(origin_m, dtype=float)
        self.rotation = board_frame(np.asarray(toward_viewer, dtype=float))
        self.size_m = (height_m * 4.0 / 3.0, height_m)

    def world_position(self, index: int) -> np.ndarray | None:
        """Where point `index` is drawn, in the world [m] (None if it is not)."""
        local = self._local.get(index)
        return None if local is None else self.origin + self.rotation @ local

    def centre_m(self) -> np.ndarray:
        width, height = self.size_m
        return self.origin + self.rotation @ np.array([0.5 * width, 0.0, 0.5 * height])

    def view(self, fov_rad: float, aspect: float) -> tuple[np.ndarray, np.ndarray]:
        """(camera position, look-at) [m] showing the whole board head on, in the left part
        of the view (the control panel floats on the right)."""
        width, height = self.size_m
        half = 0.62 * max(height, 1.35 * width / max(aspect, 0.5))
        distance = half / math.tan(0.5 * fov_rad)
        right, toward = self.rotation[:, 0], -self.rotation[:, 1]
        look_at = self.centre_m() + 0.3 * width * right
        return look_at + distance * toward, look_at

    def draw(self, points: PlotPoints, selected: int | None) -> None:
        """Draw the points (replacing the last drawing), `selected` highlighted."""
        self.remove()
        self._local = _layout(points, self.size_m)
        root = self._roots.next()
        scene = self._server.scene
        width, height = self.size_m
        radius = MARKER * height
        frame = scene.add_frame(
            root,
            show_axes=False,
            wxyz=matrix_to_wxyz(self.rotation),
            position=self.origin,
            visible=self.visible,
        )
        self._nodes = [frame]
        self._nodes.append(
            scene.add_box(
                f"{root}/backing",
                color=(250, 250, 250),
                dimensions=(width, 0.004, height),
                position=(0.5 * width, 0.006, 0.5 * height),
            )
        )
        self._draw_axes(root, points)
        for name, kinds, mesh in (
            ("solved", ("design", "fell", "front"), _sphere()),
            ("failed", ("failed",), _cross()),
        ):
            rows = [i for i, k in enumerate(points.kind) if k in kinds]
            if not rows:
                continue
            indices = [points.index[i] for i in rows]
            handle = scene.add_batched_meshes_simple(
                f"{root}/{name}",
                mesh[0],
                mesh[1],
                batched_wxyzs=np.tile([1.0, 0.0, 0.0, 0.0], (len(rows), 1)),
                batched_positions=np.array([self._local[k] for k in indices]),
                batched_scales=np.full(len(rows), radius),
                batched_colors=np.array([COLOURS[points.kind[i]] for i in rows], np.uint8),
                cast_shadow=False,
                receive_shadow=False,
                lod="off",
            )
            handle.on_click(self._picker(indices))
            self._nodes.append(handle)
        self._highlight = scene.add_cylinder(  # a disc behind the marker, not in its way
            f"{root}/selected",
            radius=2.0 * radius,
            height=0.002 * height,
            color=SELECTED_COLOUR,
            wxyz=(math.cos(math.pi / 4), math.sin(math.pi / 4), 0.0, 0.0),
            visible=False,
            cast_shadow=False,
            receive_shadow=False,
        )
        self.select(selected)

    def _picker(self, indices: list[int]) -> Callable[[Any], None]:
        def pick(event: Any) -> None:
            i = event.instance_index
            if i is not None and 0 <= i < len(indices):
                self._on_pick(indices[i], event.client)

        return pick

    def _draw_axes(self, root: str, points: PlotPoints) -> None:
        scene = self._server.scene
        width, height = self.size_m
        u0, v0 = U_RANGE[0] * width - 0.04 * width, V_AXIS * height
        top, right = 0.97 * height, 0.98 * width
        lines = np.array(
            [[[u0, -0.002, v0], [right, -0.002, v0]], [[u0, -0.002, v0], [u0, -0.002, top]]]
        )
        self._nodes.append(
            scene.add_line_segments(f"{root}/axes", lines, (40, 40, 40), thickness=0.004 * height)
        )
        x_label, y_label = points.labels
        texts: list[tuple[str, str, tuple[float, float, float], Anchor]] = [
            ("x", f"{x_label} →", (right, -0.01, v0 + 0.01 * height), "bottom-right"),
            ("y", f"↑ {y_label}", (u0, -0.01, top), "bottom-left"),
            ("title", "Pareto plot: click a point", (0.5 * width, -0.01, height), "bottom-center"),
        ]
        if points.strip_y is not None:
            texts.append(
                ("strip", "failed", (0.01 * width, -0.01, V_STRIP * height), "center-left")
            )
        placed = points.xy[np.array([k != "failed" for k in points.kind], dtype=bool)]
        placed = placed[np.isfinite(placed).all(axis=1)]
        for axis, (lo, hi) in enumerate((U_RANGE, V_RANGE) if len(placed) else ()):
            values = placed[:, axis]  # the solved points' range at the ends of the axis
            ends = [(values.min(), lo), (values.max(), hi)]
            if values.max() <= values.min():
                ends = [(values.min(), 0.5 * (lo + hi))]
            for k, (value, at) in enumerate(ends):
                spot: tuple[float, float, float] = (at * width, -0.01, v0 - 0.02 * height)
                anchor: Anchor = "top-center"
                if axis == 1:
                    spot, anchor = (u0 - 0.01 * width, -0.01, at * height), "center-right"
                texts.append((f"tick{axis}{k}", f"{value:.3g}", spot, anchor))
        for name, text, position, anchor in texts:
            self._nodes.append(
                scene.add_label(
                    f"{root}/{name}_label",
                    text,
                    position=position,
                    anchor=anchor,
                    font_screen_scale=0.8,
                )
            )

    def select(self, index: int | None) -> None:
        """Ring the point `index` (None, or a point not drawn: no ring)."""
        local = self._local.get(index) if index is not None else None
        if self._highlight is None:
            return
        if local is None:
            self._highlight.visible = False
            return
        self._highlight.position = (local[0], 0.001 * self.size_m[1], local[2])
        self._highlight.visible = True

    def set_visible(self, visible: bool) -> None:
        self.visible = visible
        if self._nodes:
            self._nodes[0].visible = visible

    def remove(self) -> None:
        self._highlight = None
        if self._nodes:
            self._nodes[0].remove()  # the root: its children go with it
        self._nodes = []


def _layout(points: PlotPoints, size_m: tuple[float, float]) -> dict[int, np.ndarray]:
    """Board-frame position of each point: the solved ones' ranges spread over U_RANGE ×
    V_RANGE, the failed strip along V_STRIP."""
    width, height = size_m
    xy = points.xy
    strip = np.zeros(len(xy), dtype=bool)
    if points.strip_y is not None:
        strip = xy[:, 1] == points.strip_y
    x_all = xy[:, 0]
    y_placed = xy[~strip, 1]

    def scale(values: np.ndarray, ref: np.ndarray, lo: float, hi: float) -> np.ndarray:
        if len(ref) == 0 or float(ref.max()) <= float(ref.min()):
            return np.full(len(values), 0.5 * (lo + hi))
        return lo + (hi - lo) * (values - ref.min()) / (ref.max() - ref.min())

    u = scale(x_all, x_all, *U_RANGE) * width
    v = np.where(strip, V_STRIP, scale(xy[:, 1], y_placed, *V_RANGE)) * height
    return {index: np.array([u[i], -0.012 * height, v[i]]) for i, index in enumerate(points.index)}
