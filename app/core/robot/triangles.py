"""Triangle meshes as plain arrays, and the URDF's primitive shapes tessellated with numpy.

A robot made of boxes, cylinders and spheres (every built-in) loads without trimesh, whose
import (scipy with it) costs about a CPU-second: trimesh reads mesh files only
(app.core.robot.meshes). The tessellations are trimesh's own (`trimesh.creation.box`,
`cylinder(sections=24)`, `icosphere(subdivisions=2)`): the same vertices, the same triangles
wound counter-clockwise seen from outside (tests/core/test_triangles.py checks them against
trimesh), so soles, hulls and drawings do not depend on which builds them.
"""

from __future__ import annotations

import dataclasses

import numpy as np

CYLINDER_SECTIONS = 24
"""Wedges of a tessellated cylinder."""
SPHERE_SUBDIVISIONS = 2
"""Times an icosahedron's triangles are split in four for a sphere (162 vertices)."""


@dataclasses.dataclass(frozen=True, eq=False)
class TriangleMesh:
    """A triangle mesh in its own frame."""

    vertices: np.ndarray
    """Vertex positions [m], shape (V, 3)."""
    faces: np.ndarray
    """Each triangle's vertex indices, counter-clockwise seen from outside, shape (F, 3)."""

    @property
    def bounds(self) -> np.ndarray:
        """Lowest and highest corner of the axis-aligned box around the vertices [m], (2, 3)."""
        return np.array([self.vertices.min(axis=0), self.vertices.max(axis=0)])

    @property
    def extents(self) -> np.ndarray:
        """Side lengths of that box [m], shape (3,)."""
        return np.ptp(self.vertices, axis=0)


# trimesh.creation's reference shapes: a unit cube's corners and triangles, and an
# icosahedron's (vertices on the unit sphere at (±1, ±φ, 0) and cyclic, normalised).
_CUBE_CORNERS = np.array([[x, y, z] for x in (0.0, 1.0) for y in (0.0, 1.0) for z in (0.0, 1.0)])
_CUBE_FACES = np.array(
    [
        [1, 3, 0],
        [4, 1, 0],
        [0, 3, 2],
        [2, 4, 0],
        [1, 7, 3],
        [5, 1, 4],
        [5, 7, 1],
        [3, 7, 2],
        [6, 4, 2],
        [2, 7, 6],
        [6, 5, 4],
        [7, 5, 6],
    ]
)
_ICOSAHEDRON_FACES = np.array(
    [
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ]
)


def _icosahedron_vertices() -> np.ndarray:
    phi = (1.0 + 5.0**0.5) / 2.0
    a, b = 1.0 / np.sqrt(1.0 + phi**2), phi / np.sqrt(1.0 + phi**2)
    return np.array(
        [
            [-a, b, 0],
            [a, b, 0],
            [-a, -b, 0],
            [a, -b, 0],
            [0, -a, b],
            [0, a, b],
            [0, -a, -b],
            [0, a, -b],
            [b, 0, -a],
            [b, 0, a],
            [-b, 0, -a],
            [-b, 0, a],
        ]
    )


def box(extents: tuple[float, ...]) -> TriangleMesh:
    """A box of side lengths `extents` [m] centred on the origin: 8 corners, 12 triangles."""
    return TriangleMesh((_CUBE_CORNERS - 0.5) * np.asarray(extents, dtype=float), _CUBE_FACES)


def cylinder(radius: float, height: float, sections: int = CYLINDER_SECTIONS) -> TriangleMesh:
    """A cylinder along z centred on the origin [m]: the two cap centres, then the bottom and
    the top ring of `sections` points each; per wedge a bottom, two side and a top triangle."""
    half = abs(float(height)) / 2.0
    theta = np.linspace(0.0, 2.0 * np.pi, sections + 1)[:-1]
    ring = np.column_stack((np.cos(theta), np.sin(theta))) * radius
    vertices = np.vstack(
        (
            [[0.0, 0.0, -half], [0.0, 0.0, half]],
            np.column_stack((ring, np.full(sections, -half))),
            np.column_stack((ring, np.full(sections, half))),
        )
    )
    k = np.arange(sections)
    bottom, top = 2 + k, 2 + sections + k
    bottom_next, top_next = 2 + (k + 1) % sections, 2 + sections + (k + 1) % sections
    faces = np.stack(
        (
            np.column_stack((np.zeros_like(k), bottom_next, bottom)),
            np.column_stack((bottom, bottom_next, top)),
            np.column_stack((top, bottom_next, top_next)),
            np.column_stack((np.ones_like(k), top, top_next)),
        ),
        axis=1,
    ).reshape(-1, 3)
    return TriangleMesh(vertices, faces)


def icosphere(radius: float, subdivisions: int = SPHERE_SUBDIVISIONS) -> TriangleMesh:
    """A sphere centred on the origin: an icosahedron whose triangles are split in four
    `subdivisions` times, the new vertices (edge midpoints) pushed out to `radius` [m]."""
    vertices, faces = _icosahedron_vertices(), _ICOSAHEDRON_FACES
    for _ in range(subdivisions):
        vertices, faces = _split_in_four(vertices, faces)
        vertices = _onto_sphere(vertices, float(radius))
    if subdivisions <= 0:
        vertices = _onto_sphere(vertices, float(radius))
    return TriangleMesh(vertices, faces)


def _split_in_four(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each triangle (a, b, c) becomes (a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca),
    one new vertex at the middle of each edge (shared by the edge's two triangles)."""
    edges = np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    unique, inverse = np.unique(edges, axis=0, return_inverse=True)
    middle = vertices[unique].mean(axis=1)
    ab, bc, ca = (inverse.reshape(-1, 3) + len(vertices)).T
    a, b, c = faces.T
    split = np.column_stack((a, ab, ca, ab, b, bc, ca, bc, c, ab, bc, ca)).reshape(-1, 3)
    return np.vstack((vertices, middle)), split


def _onto_sphere(vertices: np.ndarray, radius: float) -> np.ndarray:
    """The vertices moved along their direction from the origin to `radius` (trimesh's
    arithmetic, so the same floats)."""
    norm = np.sqrt(np.dot(vertices**2, [1, 1, 1]))
    unit = vertices / norm.reshape((-1, 1))
    return vertices + unit * (radius - norm).reshape((-1, 1))
