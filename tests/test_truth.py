"""truth.TrueSurface.closest, truth.normal_error and truth.domain_error: brute force and
analytic cases."""

from __future__ import annotations

import math
import tracemalloc

import numpy as np
import pytest
import trimesh

import scanmesh
from scanmesh.errors import ParameterError
from scanmesh.evaluate.holdout import holdout_error
from scanmesh.evaluate.truth import TrueSurface, domain_error, normal_error, point_triangle_distance
from scanmesh.scan.locate import locate


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


def box(lo, hi) -> trimesh.Trimesh:
    """A closed box from corner lo to corner hi (its shadow along z: a rectangle)."""
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    return trimesh.creation.box(extents=hi - lo).apply_translation((lo + hi) / 2)


def test_domain_error_of_a_shifted_square():
    # mesh: the unit square; truth's shadow: [0.25, 1.25] x [0, 1]
    v, f = grid_mesh(5, lambda x, y: 0 * x)
    err = domain_error((v, f), box([0.25, 0, -0.1], [1.25, 1, 0.1]), plane="z", n_rays=200_000)
    tol = 4 * err["step"]  # one ray spacing along each of the two unit-long edges, twice
    assert err["air"] == pytest.approx(0.25, abs=tol)
    assert err["missed"] == pytest.approx(0.25, abs=tol)
    assert err["truth_area"] == pytest.approx(1.0, abs=2 * tol)
    assert err["mesh_area"] == pytest.approx(1.0, abs=2 * tol)
    assert err["air_share"] == pytest.approx(err["air"] / err["truth_area"])
    # the same mesh on the truth's own shadow: nothing in air, nothing missed
    same = domain_error((v, f), box([0, 0, -0.1], [1, 1, 0.1]), plane="z", n_rays=200_000)
    assert same["air"] < tol and same["missed"] < tol


def l_shape_scan(spacing: float = 0.1):
    """Grid points over the L [0,2]x[0,1] + [0,1]x[1,2] (z = 0) and the L as two boxes."""
    g = np.arange(0, 2 + spacing / 2, spacing)
    x, y = (a.ravel() for a in np.meshgrid(g, g))
    keep = (y <= 1 + 1e-9) | (x <= 1 + 1e-9)
    pts = np.column_stack([x[keep], y[keep], np.zeros(keep.sum())])
    truth = trimesh.util.concatenate([box([0, 0, -0.1], [2, 1, 0]), box([0, 1, -0.1], [1, 2, 0])])
    return pts, truth


def test_domain_error_sees_the_hull_bridge_a_concave_corner():
    pts, truth = l_shape_scan()
    hull = scanmesh.delaunay(pts, plane="z", max_edge=math.inf)
    err = domain_error(hull, truth, n_rays=400_000)  # the Surface's own plane
    tol = 6 * err["step"]
    # the convex hull covers the notch (2,1), (1,2), (1,1): area 1/2, all of it air
    assert err["air"] == pytest.approx(0.5, abs=tol)
    assert err["missed"] < tol
    assert err["truth_area"] == pytest.approx(3.0, abs=tol)
    assert domain_error(hull, truth, plane="z", n_rays=400_000)["air"] == err["air"]
    # default trimming opens the notch again, all but triangles within max_edge of its
    # corner: the right triangle with legs max_edge at (1, 1) bounds the air they cover
    surface = scanmesh.delaunay(pts, plane="z")
    trimmed = domain_error(surface, truth, n_rays=400_000)
    assert trimmed["air"] <= surface.options["max_edge"] ** 2 / 2 + tol
    assert trimmed["missed"] < tol


def test_domain_error_checks_its_arguments():
    pts, truth = l_shape_scan(0.5)
    surface = scanmesh.delaunay(pts, plane="z")
    with pytest.raises(ParameterError, match="plane is required"):
        domain_error((surface.vertices, surface.faces), truth)
    for bad in (0, -3, 2.5, True):
        with pytest.raises(ParameterError, match="n_rays"):
            domain_error(surface, truth, n_rays=bad)


def paraboloid_scan(noise: float = 0.0, n_lines: int = 30, per_line: int = 40):
    """Scan lines (along x) of z = x^2 + y^2 over [-1, 1]^2, with Gaussian noise in z."""
    x, y = np.meshgrid(np.linspace(-1, 1, per_line), np.linspace(-1, 1, n_lines))
    z = x**2 + y**2 + np.random.default_rng(5).normal(0.0, noise, x.shape)
    points = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    return points, np.repeat(np.arange(n_lines), per_line)


@pytest.mark.slow
@pytest.mark.parametrize("by", ["points", "lines"])
def test_holdout_matches_trimesh_ray_casting(by):
    points, lines = paraboloid_scan(noise=0.01)
    result = holdout_error(points, "anneal", fraction=0.2, seed=4, by=by, lines=lines, plane="z")
    kept = result["kept"]
    withheld = np.setdiff1d(np.arange(len(points)), kept)
    assert result["n_withheld"] == len(withheld)
    mesh = trimesh.Trimesh(points[kept], result["surface"].faces, process=False)
    withheld_points = points[withheld]
    origins = withheld_points + [0.0, 0.0, 10.0]
    caster = trimesh.ray.ray_triangle.RayMeshIntersector(mesh)
    hits, ray, _ = caster.intersects_location(
        origins, np.tile([0.0, 0.0, -1.0], (len(origins), 1)), multiple_hits=False
    )
    dist = np.abs(withheld_points[ray, 2] - hits[:, 2])
    assert result["n_measured"] == len(ray)
    assert result["outside"] == len(withheld) - len(ray)
    assert result["rms"] == pytest.approx(np.sqrt(np.mean(dist**2)), rel=1e-9)
    assert result["max"] == pytest.approx(dist.max(), rel=1e-9)
    assert result["p99"] == pytest.approx(np.percentile(dist, 99), rel=1e-9)
    if by == "lines":
        out_lines = np.unique(lines[withheld])
        assert len(out_lines) == 6  # 20 % of 30 lines
        assert not np.isin(lines[kept], out_lines).any()  # whole lines only


def test_holdout_on_a_plane_is_exact_and_seeded():
    points, lines = paraboloid_scan()
    points[:, 2] = 0.3 * points[:, 0] - 0.2 * points[:, 1] + 1.0
    first = holdout_error(points, "delaunay", fraction=0.1, seed=1, plane="z")
    again = holdout_error(points, "delaunay", fraction=0.1, seed=1, plane="z")
    other = holdout_error(points, "delaunay", fraction=0.1, seed=2, plane="z")
    assert first["n_withheld"] == 120
    assert first["rms"] < 1e-12 and first["max"] < 1e-12
    assert np.array_equal(first["kept"], again["kept"])
    assert not np.array_equal(first["kept"], other["kept"])
    assert first["n_measured"] + first["outside"] == first["n_withheld"]


def test_holdout_refuses_bad_arguments():
    points, lines = paraboloid_scan()
    for kwargs, match in [
        ({"fraction": 0.0}, "fraction"),
        ({"fraction": 1.0}, "fraction"),
        ({"fraction": 0.0001}, "withholds 0"),
        ({"by": "rows"}, "by must be"),
        ({"seed": -1}, "seed"),
    ]:
        with pytest.raises(ParameterError, match=match):
            holdout_error(points, "delaunay", plane="z", **kwargs)


def _brute_force_locate(q, tri_uv):
    a, b, c = tri_uv[:, 0], tri_uv[:, 1], tri_uv[:, 2]

    def side(p0, p1):
        return (p1[None, :, 0] - p0[None, :, 0]) * (q[:, None, 1] - p0[None, :, 1]) - (
            p1[None, :, 1] - p0[None, :, 1]
        ) * (q[:, None, 0] - p0[None, :, 0])

    s = np.stack([side(a, b), side(b, c), side(c, a)])
    inside = np.all(s >= 0, axis=0) | np.all(s <= 0, axis=0)  # (Q, F)
    return np.where(inside.any(axis=1), inside.argmax(axis=1), -1)


def test_locate_matches_brute_force():
    rng = np.random.default_rng(2)
    v, faces = grid_mesh(12, lambda x, y: 0 * x)
    v[:, :2] += rng.uniform(-0.02, 0.02, (len(v), 2))  # uneven, still a valid triangulation
    tri_uv = v[faces][:, :, :2]
    q = rng.uniform(-0.1, 1.1, (2000, 2))
    found = locate(q, tri_uv)
    assert np.array_equal(found, _brute_force_locate(q, tri_uv))
    assert (found >= 0).sum() > 1000 and (found < 0).sum() > 100


def test_locate_of_clusters_far_apart_stays_small():
    # Two tight clusters joined by long triangles (the fuzz's "clusters" points): binned in
    # cells of the small triangles' size, each long one covered 4096 x 4096 cells (55.7M
    # entries, 425 MiB for 60 points, a MemoryError under a 2 GiB limit).
    rng = np.random.default_rng(3)
    small = rng.uniform(0, 1e-4, (40, 3, 2))
    small[20:] += 1.0
    long = np.array(
        [[[0, 0], [1, 1], [0, 1]], [[0, 0], [1, 0], [1, 1]], [[0, 0], [1, 1], [0.5, 0.6]]]
    )
    tri_uv = np.concatenate([small, long.astype(float)])
    q = np.concatenate([rng.uniform(-0.1, 1.1, (300, 2)), small.mean(axis=1)])
    tracemalloc.start()
    try:
        found = locate(q, tri_uv)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 8 << 20, f"{peak / 2**20:.0f} MiB"
    assert np.array_equal(found, _brute_force_locate(q, tri_uv))
    assert (found[:300] >= len(small)).sum() > 100 and (found[300:] >= 0).all()
