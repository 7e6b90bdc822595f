"""Planar Delaunay: agreement with scipy, max-min optimality, scale invariance, trimming."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from scipy.spatial import Delaunay as ScipyDelaunay

import scanmesh
from conftest import bumpy_patch
from scanmesh import _core
from scanmesh.stages.options import JUMP_FACTOR, MAX_EDGE_FACTOR


def canonical(faces: np.ndarray) -> np.ndarray:
    """Faces as sorted rows in a sorted array: connectivity without orientation or order."""
    return np.unique(np.sort(np.asarray(faces), axis=1), axis=0)


def test_matches_scipy_on_the_convex_hull():
    pts = bumpy_patch(800, 1)
    ours = scanmesh.delaunay(pts, plane="z", max_edge=math.inf)
    theirs = ScipyDelaunay(pts[:, :2])
    assert np.array_equal(canonical(ours.faces), canonical(theirs.simplices))


def test_scan_ordered_lines_match_scipy_and_trim_as_two_calls():
    # Points as a scanner delivers them, line by line, jittered: the native sweep's path.
    rng = np.random.default_rng(5)
    lines, per = 40, 120
    x = np.tile(np.arange(per, dtype=float), lines) + rng.uniform(-0.05, 0.05, lines * per)
    y = np.repeat(np.arange(lines) * 2.5, per) + rng.uniform(-0.1, 0.1, lines * per)
    z = np.sin(x / 9) * 4 + np.where(x > 60, 6.0, 0.0)  # a wall: depth-jump trimming
    pts = np.column_stack([x, y, z])
    hull = scanmesh.delaunay(pts, plane="z", max_edge=math.inf)
    assert np.array_equal(canonical(hull.faces), canonical(ScipyDelaunay(pts[:, :2]).simplices))
    # The one native call trims as the separate triangulation and trimming calls do.
    ours = scanmesh.delaunay(pts, plane="z")
    faces, _ = _core.delaunay(pts[:, :2].copy())
    limit = MAX_EDGE_FACTOR * _core.median_spacing(pts[:, :2].copy(), faces)
    assert ours.options["max_edge"] == pytest.approx(limit, rel=1e-12)
    two = _core.trim_long_edges(
        pts[:, :2].copy(), faces, ours.options["max_edge"], pts, JUMP_FACTOR
    )
    assert np.array_equal(canonical(ours.faces), canonical(two))
    assert len(ours.faces) < len(hull.faces)


def test_faces_index_the_callers_points_in_order():
    pts = bumpy_patch(300, 2)
    s = scanmesh.delaunay(pts, plane="z")
    assert s.vertices.shape == pts.shape and np.array_equal(s.vertices, pts)
    assert s.faces.dtype == np.int64 and s.faces.shape[1] == 3
    # Counter-clockwise seen against the viewing normal +z.
    tri = pts[s.faces][:, :, :2]
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    cross = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    assert (cross > 0).all()


def test_no_single_flip_raises_the_smallest_planar_angle():
    pts = bumpy_patch(500, 3)
    s = scanmesh.delaunay(pts, plane="z", max_edge=math.inf)
    uv, _ = scanmesh.project(pts, "z")
    faces, flips = _core.lop(pts, uv, s.faces, "max-min")
    assert flips == 0
    assert np.array_equal(canonical(faces), canonical(s.faces))


def test_planar_lop_from_a_scrambled_state_returns_to_delaunay():
    pts = bumpy_patch(400, 4)
    d = scanmesh.delaunay(pts, plane="z", max_edge=math.inf)
    scrambled = scanmesh.reconstruct(
        pts, "anneal", plane="z", max_edge=math.inf, sweeps=5, polish=False, sliver_guard=False
    )
    assert not np.array_equal(canonical(scrambled.faces), canonical(d.faces))
    back = scanmesh.reconstruct(pts, "lop", plane="z", max_edge=math.inf, criterion="max-min")
    assert np.array_equal(canonical(back.faces), canonical(d.faces))


@pytest.mark.parametrize("scale", [1e-6, 1e6])
def test_rescaled_input_gives_the_same_connectivity(scale):
    pts = bumpy_patch(400, 5)
    base = scanmesh.delaunay(pts)
    scaled = scanmesh.delaunay(pts * scale)
    assert np.array_equal(canonical(base.faces), canonical(scaled.faces))


def test_trimming_opens_a_hole_and_inf_keeps_the_hull():
    g = np.stack(np.meshgrid(np.arange(30.0), np.arange(30.0)), -1).reshape(-1, 2)
    g += np.random.default_rng(6).normal(0, 0.02, g.shape)
    hole = np.hypot(g[:, 0] - 15, g[:, 1] - 15) < 6
    pts = np.column_stack([g[~hole], np.zeros((~hole).sum())])
    trimmed = scanmesh.delaunay(pts, plane="z")
    full = scanmesh.delaunay(pts, plane="z", max_edge=math.inf)
    centre = np.array([15.0, 15.0])

    def covered(s):
        tri = pts[s.faces][:, :, :2]

        def side(k):
            e, w = tri[:, (k + 1) % 3] - tri[:, k], centre - tri[:, k]
            return e[:, 0] * w[:, 1] - e[:, 1] * w[:, 0]

        signs = [side(k) for k in range(3)]
        return bool(np.any(np.all(np.array(signs) > 0, axis=0)))

    assert covered(full) and not covered(trimmed)
    uv, _ = scanmesh.project(pts, "z")
    _core.validate(uv, trimmed.faces)
    assert len(full.faces) > len(trimmed.faces)


def test_coincident_points_are_reported():
    pts = bumpy_patch(100, 7)
    dup = np.vstack([pts, pts[[3, 3]], pts[[10]] + [0, 0, 0.5]])
    with pytest.warns(scanmesh.CoincidentPointsWarning, match="3 point"):
        s = scanmesh.delaunay(dup, plane="z")
    assert s.duplicates.tolist() == [[100, 3], [101, 3], [102, 10]]
    assert not np.isin([100, 101, 102], s.faces).any()


def test_surface_round_trips_through_trimesh(tmp_path):
    pts = bumpy_patch(200, 8)
    s = scanmesh.delaunay(pts)
    mesh = s.to_trimesh()
    assert np.array_equal(mesh.faces, s.faces) and np.array_equal(mesh.vertices, pts)
    out = s.save(tmp_path / "m.ply")
    import trimesh

    back = trimesh.load(out, process=False)
    assert len(back.faces) == len(s.faces)
    assert [p.name for p in tmp_path.iterdir()] == ["m.ply"]


def test_any_dtype_and_layout_is_accepted():
    pts = bumpy_patch(150, 9)
    ref = canonical(scanmesh.delaunay(pts).faces)
    variants = [
        pts.astype(np.float32).astype(np.float64),
        np.asfortranarray(pts),
        np.repeat(pts, 2, axis=0)[::2],
        pts.tolist(),
    ]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for v in variants:
            assert np.array_equal(canonical(scanmesh.delaunay(v).faces), ref)
    ints = np.round(bumpy_patch(150, 9) * 1000).astype(np.int32)
    assert len(scanmesh.delaunay(ints).faces) > 0
