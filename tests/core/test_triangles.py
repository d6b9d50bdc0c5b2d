"""The primitive shapes tessellated without trimesh are trimesh's own: the same vertices, the
same triangles wound the same way (trimesh is the oracle, imported here only)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from app.core.robot import triangles


def _oriented_triangles(vertices: np.ndarray, faces: np.ndarray) -> list[tuple]:
    """Each triangle as its corner coordinates, rotated to start at its smallest corner (the
    winding kept), sorted: two meshes with the same list have the same oriented triangles
    whatever their vertex numbering."""
    out = []
    for face in faces:
        corners = [tuple(vertices[i]) for i in face]
        start = corners.index(min(corners))
        out.append(tuple(corners[start:] + corners[:start]))
    return sorted(out)


@pytest.mark.parametrize(
    "ours, theirs",
    [
        (
            lambda: triangles.box((0.12, 0.05, 0.3)),
            lambda: trimesh.creation.box(extents=(0.12, 0.05, 0.3)),
        ),
        (
            lambda: triangles.cylinder(0.031, 0.27),
            lambda: trimesh.creation.cylinder(radius=0.031, height=0.27, sections=24),
        ),
        (
            lambda: triangles.icosphere(0.045),
            lambda: trimesh.creation.icosphere(subdivisions=2, radius=0.045),
        ),
    ],
    ids=["box", "cylinder", "sphere"],
)
def test_primitives_are_trimesh_s(ours, theirs):
    mesh, reference = ours(), theirs()
    assert mesh.vertices.shape == reference.vertices.shape
    assert mesh.faces.shape == reference.faces.shape
    assert np.array_equal(  # the same floats, not only close ones
        np.unique(mesh.vertices, axis=0), np.unique(np.asarray(reference.vertices), axis=0)
    )
    assert _oriented_triangles(mesh.vertices, mesh.faces) == _oriented_triangles(
        np.asarray(reference.vertices), np.asarray(reference.faces)
    )
    assert np.array_equal(mesh.bounds, reference.bounds)
    assert np.array_equal(mesh.extents, reference.extents)
    closed = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    assert closed.is_watertight and closed.volume == pytest.approx(reference.volume, rel=1e-12)
    assert closed.volume > 0  # wound counter-clockwise seen from outside
