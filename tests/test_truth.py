"""truth.TrueSurface.closest and truth.normal_error: brute force and analytic cases."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

from scanmesh.errors import ParameterError
from scanmesh.truth import TrueSurface, normal_error, point_triangle_distance


def grid_mesh(n: int, height) -> tuple[np.ndarray, np.ndarray]:
    """(vertices, faces) of z = height(x, y) on an n x n grid over the unit square."""
    x, y = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
    v = np.column_stack([x.ravel(), y.ravel(), height(x.ravel(), y.ravel())])
    i = np.arange(n - 1)
    a = (i[:, None] * n + i[None, :]).ravel()  # lower-left corner of each cell
    faces = np.concatenate(
        [np.column_stack([a, a + 1, a + n + 1]), np.column_stack([a, a + n + 1, a + n])]
    )
    return v, faces


def flat_truth(margin: float = 1.0) -> trimesh.Trimesh:
    """The plane z = 0 as two large triangles covering the unit square with a margin."""
    lo, hi = -margin, 1 + margin
    v = np.array([[lo, lo, 0], [hi, lo, 0], [hi, hi, 0], [lo, hi, 0]], dtype=float)
    return trimesh.Trimesh(v, np.array([[0, 1, 2], [0, 2, 3]]), process=False)


def test_closest_matches_brute_force():
    truth = trimesh.creation.icosphere(subdivisions=2)
    surface = TrueSurface(truth)
    rng = np.random.default_rng(3)
    pts = np.concatenate([rng.normal(size=(300, 3)) * 0.7, rng.normal(size=(100, 3)) * 4])
    dist, tri = surface.closest(pts)
    tris = surface.triangles
    every = point_triangle_distance(
        np.repeat(tris[None], len(pts), axis=0).reshape(-1, 3, 3), np.repeat(pts, len(tris), 0)
    ).reshape(len(pts), len(tris))
    np.testing.assert_allclose(dist, every.min(axis=1), rtol=1e-12, atol=1e-14)
    assert tri.min() >= 0
    # the triangle named attains the distance
    np.testing.assert_allclose(every[np.arange(len(pts)), tri], dist, rtol=1e-12, atol=1e-14)
    np.testing.assert_array_equal(surface.distance(pts), dist)


@pytest.mark.parametrize("degrees", [0.0, 5.0, 20.0, 45.0, 70.0])
def test_tilted_plane_over_flat_truth(degrees):
    slope = math.tan(math.radians(degrees))
    v, f = grid_mesh(6, lambda x, y: 0.01 + slope * x)
    err = normal_error((v, f), flat_truth(margin=3.0), n_samples=2000, seed=1)
    assert err["n_mean_deg"] == pytest.approx(degrees, abs=1e-9)
    assert err["n_max_deg"] == pytest.approx(degrees, abs=1e-9)
    assert err["n_rms_deg"] == pytest.approx(degrees, abs=1e-9)
    assert err["n_samples"] == 2000
    # orientation does not matter
    flipped = normal_error((v, f[:, ::-1]), flat_truth(margin=3.0), n_samples=2000, seed=1)
    assert flipped["n_mean_deg"] == pytest.approx(err["n_mean_deg"], abs=1e-12)


def test_tent_over_flat_truth_and_on_itself():
    tent = lambda x, y: 0.2 * np.abs(x - 0.5)  # noqa: E731  (creased along x = 0.5)
    v, f = grid_mesh(5, tent)  # grid lines at x = 0.5: the crease is a mesh edge
    expected = math.degrees(math.atan(0.2))
    err = normal_error((v, f), flat_truth(), n_samples=5000, seed=0)
    assert err["n_mean_deg"] == pytest.approx(expected, abs=1e-9)
    # against itself (same surface, other triangles): zero apart from round-off
    tv, tf = grid_mesh(3, tent)
    same = normal_error((v, f), trimesh.Trimesh(tv, tf, process=False), n_samples=5000)
    assert same["n_max_deg"] < 1e-6


def test_half_tilted_mean():
    """Half the area tilted by 30 degrees, half flat: the mean is 15 degrees (by area)."""
    slope = math.tan(math.radians(30))
    v, f = grid_mesh(3, lambda x, y: 0.001 + np.where(x > 0.5, slope * (x - 0.5), 0.0))
    tilted_area = 0.5 / math.cos(math.radians(30))
    share = tilted_area / (tilted_area + 0.5)
    err = normal_error((v, f), flat_truth(), n_samples=100_000, seed=2)
    assert err["n_mean_deg"] == pytest.approx(30 * share, abs=0.3)
    assert err["n_median_deg"] == pytest.approx(30.0, abs=1e-9)


def test_normal_error_checks_samples():
    v, f = grid_mesh(3, lambda x, y: 0 * x)
    with pytest.raises(ParameterError):
        normal_error((v, f), flat_truth(), n_samples=0)
