"""Quality criteria against independent implementations (trimesh) and by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

import scanmesh
from conftest import bumpy_patch
from scanmesh.measures import SLIVER_ANGLE_DEG


def interior_mask(faces: np.ndarray, n: int) -> np.ndarray:
    """Vertices touched by no boundary edge (an edge used by one face), computed by trimesh."""
    mesh = trimesh.Trimesh(np.zeros((n, 3)), faces, process=False)
    once = trimesh.grouping.group_rows(mesh.edges_sorted, require_count=1)
    boundary_edges = mesh.edges_sorted[once]
    mask = np.isin(np.arange(n), np.unique(faces))
    mask[np.unique(boundary_edges)] = False
    return mask


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_tac_equals_trimesh_vertex_defects_on_random_patches(seed):
    pts = bumpy_patch(400, seed)
    s = scanmesh.delaunay(pts)
    q = s.quality
    defects = s.to_trimesh().vertex_defects
    inner = interior_mask(s.faces, len(pts))
    assert q.n_interior == inner.sum() > 200
    assert np.array_equal(~np.isnan(q.tac), inner)
    np.testing.assert_allclose(q.tac[inner], np.abs(defects[inner]), rtol=0, atol=1e-12)


def test_tac_equals_trimesh_on_the_real_rod_scan(rod_scan):
    pts, _ = rod_scan
    s = scanmesh.delaunay(pts, plane="y")
    q = s.quality
    defects = s.to_trimesh().vertex_defects
    inner = ~np.isnan(q.tac)
    assert inner.sum() > 10_000
    np.testing.assert_allclose(q.tac[inner], np.abs(defects[inner]), rtol=0, atol=1e-12)


def test_norms_and_smallest_angle_by_hand():
    pts = bumpy_patch(300, 4)
    q = scanmesh.delaunay(pts).quality
    t = q.tac[~np.isnan(q.tac)]
    assert math.isclose(q.tac_1, t.sum(), rel_tol=1e-12)
    assert math.isclose(q.tac_2, math.sqrt((t**2).sum()), rel_tol=1e-12)
    assert q.tac_inf == t.max()
    assert math.isclose(q.tac_norm(3), (t**3).sum() ** (1 / 3), rel_tol=1e-12)
    s = scanmesh.delaunay(pts)
    tri = pts[s.faces]
    angles = []
    for k in range(3):
        u = tri[:, (k + 1) % 3] - tri[:, k]
        v = tri[:, (k + 2) % 3] - tri[:, k]
        sine = np.linalg.norm(np.cross(u, v), axis=1)
        angles.append(np.degrees(np.arctan2(sine, (u * v).sum(1))))
    smallest = np.min(angles, axis=0)
    assert math.isclose(q.min_angle_deg, smallest.min(), rel_tol=1e-12)
    assert q.sliver_fraction == pytest.approx((smallest < 5).mean())


def test_flat_grid_has_zero_tac_and_bent_grid_has_its_fold():
    g = np.stack(np.meshgrid(np.arange(6.0), np.arange(6.0)), -1).reshape(-1, 2)
    flat = np.column_stack([g, np.zeros(len(g))])
    q = scanmesh.delaunay(flat, plane="z", max_edge=math.inf).quality
    assert q.n_interior == 16 and q.tac_1 < 1e-12
    # Folded along one line the grid stays developable (tac 0 up to rounding); folded along
    # two, the vertices next to both folds are cone points with a real angle defect.
    bent = flat.copy()
    bent[:, 2] = np.abs(bent[:, 0] - 2.5) + np.abs(bent[:, 1] - 2.5)
    bent_faces = scanmesh.delaunay(bent, plane="z", max_edge=math.inf).faces
    assert scanmesh.quality(bent, bent_faces).tac_1 > 0.1


def test_comparison_of_triangulations():
    pts = bumpy_patch(300, 5)
    d = scanmesh.delaunay(pts).quality
    a = scanmesh.reconstruct(pts, "anneal", sweeps=50).quality
    assert a.better_than(d, 1) and not d.better_than(a, 1)
    assert a.tac_norm(1) == pytest.approx(a.tac_1)
    with pytest.raises(scanmesh.ParameterError, match="p"):
        a.tac_norm(0.5)


def test_quality_rejects_bad_faces():
    pts = bumpy_patch(10, 6)
    with pytest.raises(scanmesh.InvalidMeshError, match="face 1"):
        scanmesh.quality(pts, [[0, 1, 2], [0, 1, 99]])
    with pytest.raises(scanmesh.InvalidMeshError, match=r"\(M, 3\)"):
        scanmesh.quality(pts, [[0, 1]])
    with pytest.raises(scanmesh.InvalidMeshError, match="repeats"):
        scanmesh.quality(pts, [[0, 1, 1]])


def test_sliver_share_is_counted_on_radians_as_on_degrees():
    """quality() counts slivers on the radians against _SLIVER_RADIANS: the same verdict as
    converting every angle to degrees first, at the limit's neighbouring floats too."""
    from scanmesh.measures import _SLIVER_RADIANS

    r = _SLIVER_RADIANS
    near = [np.nextafter(r, 0.0), r, np.nextafter(r, 1.0), math.radians(SLIVER_ANGLE_DEG)]
    rng = np.random.default_rng(4)
    a = np.concatenate([near, rng.uniform(0.0, 0.2, 5000), r + rng.normal(0, 1e-15, 1000)])
    np.testing.assert_array_equal(a < r, np.degrees(a) < SLIVER_ANGLE_DEG)
    pts = np.column_stack([rng.random((400, 2)), 0.05 * rng.random(400)])
    q = scanmesh.quality(pts, scanmesh.delaunay(pts).faces)
    np.testing.assert_array_equal(q.face_min_angle_deg, np.degrees(q.face_min_angle))
    assert q.sliver_fraction == np.mean(q.face_min_angle_deg < SLIVER_ANGLE_DEG)
    assert q.min_angle_deg == q.face_min_angle_deg.min()
