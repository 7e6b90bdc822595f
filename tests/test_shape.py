"""Surface's plain geometry: normals, area and boundary loops, checked on meshes whose
answers are known by construction."""

from __future__ import annotations

import numpy as np

import scanmesh


def _sheet(n: int = 11, hole: bool = False):
    x, y = np.meshgrid(np.linspace(0, 2, n), np.linspace(0, 1, n))
    pts = np.column_stack([x.ravel(), y.ravel(), np.zeros(n * n)])
    if hole:  # drop the points in a square in the middle: a hole the trimming keeps open
        keep = ~((np.abs(pts[:, 0] - 1) < 0.35) & (np.abs(pts[:, 1] - 0.5) < 0.25))
        pts = pts[keep]
    return pts


def test_area_and_normals_of_a_tilted_rectangle():
    pts = _sheet()
    c, s = np.cos(0.3), np.sin(0.3)
    tilted = pts @ np.array([[1, 0, 0], [0, c, -s], [0, s, c]]).T + [5, 7, 9]
    surface = scanmesh.delaunay(tilted, plane="best-fit")
    assert np.isclose(surface.area, 2.0)
    normal = surface.face_normals[0] * np.sign(surface.face_normals[0] @ [0, -s, c])
    np.testing.assert_allclose(normal, [0, -s, c], atol=1e-12)
    used = np.unique(surface.faces)
    np.testing.assert_allclose(np.abs(surface.normals[used] @ [0, -s, c]), 1.0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(surface.face_normals, axis=1), 1.0)


def test_boundary_loops_are_the_outline_and_the_holes():
    surface = scanmesh.delaunay(_sheet(), plane="z")
    (outline,) = surface.boundary_loops()
    assert len(outline) == 40 and len(set(outline.tolist())) == 40  # the grid's rim points
    edges = {tuple(sorted(e)) for e in zip(outline, np.roll(outline, -1), strict=True)}
    face_edges = [
        tuple(sorted(e)) for f in surface.faces for e in ((f[0], f[1]), (f[1], f[2]), (f[2], f[0]))
    ]
    assert all(face_edges.count(e) == 1 for e in edges)  # each loop edge borders one face
    holed = scanmesh.delaunay(_sheet(hole=True), plane="z")
    loops = holed.boundary_loops()
    assert len(loops) == 2
    inner = min(loops, key=len)
    assert np.all(np.abs(holed.vertices[inner, 0] - 1) < 0.5)
