"""Decimation for display: a notebook view of a million faces stays under 5 MB, says it is
decimated, and the coarse copy keeps the surface (area, heights, winding)."""

from __future__ import annotations

import html

import numpy as np
import pytest

from scanmesh import shape
from scanmesh.present.decimate import cluster
from scanmesh.present.view import NOTEBOOK_FACES, notebook_html


def bumpy_grid(n: int):
    """An n x n grid on z = 0.1 sin(3x) cos(2y) over the unit square, two faces a cell,
    counter-clockwise seen from +z."""
    x, y = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
    z = 0.1 * np.sin(3 * x) * np.cos(2 * y)
    vertices = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    k = np.arange(n * n).reshape(n, n)[:-1, :-1].ravel()
    faces = np.concatenate(
        [np.column_stack([k, k + 1, k + n + 1]), np.column_stack([k, k + n + 1, k + n])]
    )
    return vertices, faces


@pytest.fixture(scope="module")
def million():
    return bumpy_grid(710)  # 1,005,362 faces


@pytest.mark.slow
def test_a_million_faces_in_a_notebook_take_at_most_5_mb(million):
    vertices, faces = million
    assert len(faces) > 1_000_000
    shown = notebook_html((vertices, faces))
    assert len(shown.encode("utf-8")) <= 5_000_000
    assert "faces)" in shown and f"of {len(faces):,} faces" in html.unescape(shown)
    assert "decimated for display" in html.unescape(shown)


@pytest.mark.slow
def test_the_coarse_copy_keeps_the_surface(million):
    vertices, faces = million
    v, f = cluster(vertices, faces, NOTEBOOK_FACES)
    assert NOTEBOOK_FACES // 3 < len(f) <= NOTEBOOK_FACES
    assert shape.area(v, f) == pytest.approx(shape.area(vertices, faces), rel=0.02)
    # each merged vertex lies close to the true surface (means of nearby samples)
    z = 0.1 * np.sin(3 * v[:, 0]) * np.cos(2 * v[:, 1])
    assert np.abs(v[:, 2] - z).max() < 2e-3
    # winding kept: every face still faces up
    assert (shape.face_normals(v, f)[:, 2] > 0).all()
    assert len(np.unique(np.sort(f, axis=1), axis=0)) == len(f)  # no face twice


def test_small_meshes_are_shown_whole():
    vertices, faces = bumpy_grid(20)
    v, f = cluster(vertices, faces, len(faces))
    assert v is not None and np.array_equal(f, faces)
    shown = html.unescape(notebook_html((vertices, faces)))
    assert "decimated" not in shown
