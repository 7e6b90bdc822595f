"""Triangles that bridge a depth jump (a wall, a bore) are dropped by every Delaunay-based
method, and flips never bring them back."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import scanmesh
from scanmesh import _core
from scanmesh.scan.projection import project
from scanmesh.stages.options import JUMP_FACTOR
from scanmesh.stages.strips import strip_surface


def terraced_scan(wall: float = 8.0) -> np.ndarray:
    """A 24 x 24 jittered grid (spacing 1): a plateau `wall` high at x >= 12 with a blind
    bore (radius 3, depth `wall`) in its middle; the low terrace gently bumpy."""
    rng = np.random.default_rng(5)
    x, y = np.meshgrid(np.arange(24.0), np.arange(24.0))
    x = x.ravel() + rng.uniform(-0.05, 0.05, x.size)
    y = y.ravel()
    z = 0.2 * np.sin(0.4 * x) * np.cos(0.3 * y)
    high = x >= 11.5
    bore = (x - 17.5) ** 2 + (y - 11.5) ** 2 < 9.0
    z = np.where(high & ~bore, z + wall, z)
    return np.column_stack([x, y, z])


def bridging(points: np.ndarray, faces: np.ndarray, wall: float) -> int:
    """Faces whose corners lie on different levels (heights more than wall / 2 apart)."""
    z = points[faces, 2]
    return int(np.count_nonzero(np.ptp(z, axis=1) > wall / 2))


def boundary_edges(faces: np.ndarray) -> set[tuple[int, int]]:
    e = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    keys, counts = np.unique(e, axis=0, return_counts=True)
    return {tuple(k) for k in keys[counts == 1].tolist()}


def test_untrimmed_delaunay_bridges_the_jumps_and_the_default_does_not():
    pts = terraced_scan()
    uv, _ = project(pts, "z")
    hull, _ = _core.delaunay(uv)
    limit = scanmesh.delaunay(pts, plane="z").options["max_edge"]
    planar_only = _core.trim_long_edges(uv, hull, limit)
    assert bridging(pts, planar_only, 8.0) > 40  # the fixture has curtains to drop
    d = scanmesh.delaunay(pts, plane="z")
    assert bridging(pts, d.faces, 8.0) == 0
    _core.validate(uv, d.faces)
    # Every point is in a face or listed as trimmed.
    used = np.zeros(len(pts), dtype=bool)
    used[d.faces.ravel()] = True
    used[d.options["trimmed"]] = True
    assert used.all()
    # What was dropped is the bridging faces (no bump of a terrace is lost), and at most a
    # few more where a drop left a pinch behind.
    dropped, bridges = len(planar_only) - len(d.faces), bridging(pts, planar_only, 8.0)
    assert bridges <= dropped <= bridges + 3


def test_small_steps_and_max_edge_inf_keep_every_face():
    pts = terraced_scan(wall=0.5)
    uv, _ = project(pts, "z")
    hull, _ = _core.delaunay(uv)
    assert len(scanmesh.delaunay(pts, plane="z", max_edge=math.inf).faces) == len(hull)
    tall = terraced_scan()
    assert len(scanmesh.delaunay(tall, plane="z", max_edge=math.inf).faces) == len(hull)
    # A step of half a spacing is no jump: what goes beyond planar trimming are only faces
    # already long in the plane (hull fillers along the jittered outline).
    planar = _core.trim_long_edges(uv, hull, 5.0)
    kept = {tuple(sorted(f)) for f in scanmesh.delaunay(pts, plane="z", max_edge=5.0).faces}
    gone = np.array([f for f in planar.tolist() if tuple(sorted(f)) not in kept])
    assert len(gone) < 0.01 * len(planar)
    if len(gone):
        edges = np.linalg.norm(uv[gone] - uv[np.roll(gone, 1, axis=1)], axis=2)
        assert edges.max(axis=1).min() > JUMP_FACTOR


@pytest.mark.parametrize("method", ["lop", "anneal"])
def test_flips_never_bring_a_dropped_region_back(method):
    pts = terraced_scan()
    start = scanmesh.delaunay(pts, plane="z")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        kwargs = {"seed": 1, "sweeps": 30} if method == "anneal" else {}
        s = scanmesh.reconstruct(pts, method, plane="z", **kwargs)
    assert bridging(pts, s.faces, 8.0) == 0
    # Flips change interior edges only: the same outline, the same points used.
    assert boundary_edges(s.faces) == boundary_edges(start.faces)
    assert np.array_equal(np.unique(s.faces), np.unique(start.faces))
    np.testing.assert_array_equal(s.options["trimmed"], start.options["trimmed"])


def test_jump_factor_is_validated_and_documented():
    pts = terraced_scan()
    uv, _ = project(pts, "z")
    hull, _ = _core.delaunay(uv)
    for bad in (0.0, -1.0, math.nan):
        with pytest.raises(scanmesh.errors.ParameterError, match="jump_factor"):
            _core.trim_long_edges(uv, hull, 5.0, pts, bad)
    with pytest.raises(scanmesh.errors.ParameterError, match="points"):
        _core.trim_long_edges(uv, hull, 5.0, pts[:-1], JUMP_FACTOR)
    assert JUMP_FACTOR == _core.DEFAULT_JUMP_FACTOR > 1


def terraced_lines(along: str) -> tuple[np.ndarray, np.ndarray]:
    """The terraced scan as scan lines: along x (the wall and the bore cut every line) or
    along y (the wall runs between two lines, parallel to them)."""
    pts = terraced_scan()
    ids = np.rint(pts[:, 1] if along == "x" else pts[:, 0]).astype(np.int64)
    order = np.argsort(ids, kind="stable")
    return pts[order], ids[order]


@pytest.mark.parametrize("method", ["shortest-path", "lookahead"])
@pytest.mark.parametrize("along", ["x", "y"])
def test_strips_leave_walls_steps_and_bores_open(method, along):
    pts, ids = terraced_lines(along)
    whole = strip_surface(pts, lines=ids, plane="z", method=method, jump_factor=math.inf)
    assert bridging(pts, whole.faces, 8.0) > 40  # without the rule: curtains
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no crossing, no unused point
        s = strip_surface(pts, lines=ids, plane="z", method=method)
    assert bridging(pts, s.faces, 8.0) == 0
    _core.validate(s.scan.uv, s.faces)
    # Every piece is stitched to its neighbours: every point is used, and the mesh covers
    # what trimmed Delaunay covers, within a few triangles' area.
    assert len(s.options["unused"]) == len(s.options["trimmed"]) == 0
    d = scanmesh.delaunay(pts, plane="z")

    def area(faces: np.ndarray) -> float:
        a, b, c = (pts[faces[:, k], :2] for k in range(3))
        u, v = b - a, c - a
        return 0.5 * float(np.abs(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]).sum())

    assert area(s.faces) == pytest.approx(area(d.faces), rel=0.04)
    if along == "y":  # the wall lies between two lines: that strip's triangles are dropped
        assert s.options["dropped_jumps"] >= 23


def banded_lines(gap: float) -> tuple[np.ndarray, np.ndarray]:
    """A flat, gently bumpy scan: 30-point lines (step 1, jittered) 1 apart in two bands
    of 6 lines, `gap` apart (no line in between: a missed stretch of the scan)."""
    rng = np.random.default_rng(7)
    ys = np.concatenate([np.arange(6.0), 5.0 + gap + np.arange(6.0)])
    x, y = np.meshgrid(np.arange(30.0), ys)
    x = x + rng.uniform(-0.05, 0.05, x.shape)
    z = 0.1 * np.sin(0.3 * x) * np.cos(0.2 * y)
    line = np.repeat(np.arange(len(ys)), 30)
    return np.column_stack([x.ravel(), y.ravel(), z.ravel()]), line


def spanning(points: np.ndarray, faces: np.ndarray) -> int:
    """Faces with corners in both bands."""
    low = points[faces, 1] < 5.5
    return int(np.count_nonzero(low.any(axis=1) & ~low.all(axis=1)))


def planar_area(points: np.ndarray, faces: np.ndarray) -> float:
    a, b, c = (points[faces[:, k], :2] for k in range(3))
    (ux, uy), (vx, vy) = (b - a).T, (c - a).T
    return float(0.5 * np.abs(ux * vy - uy * vx).sum())


def test_delaunay_leaves_a_gap_narrower_than_max_edge_open():
    pts, _ = banded_lines(gap=8.0)
    # max_edge above the gap: the planar rule keeps the sheet over it, the bridge rule not.
    d = scanmesh.delaunay(pts, plane="z", max_edge=20.0)
    assert spanning(pts, d.faces) == 0
    uv, _ = project(pts, "z")
    hull, _ = _core.delaunay(uv)
    planar_only = _core.trim_long_edges(uv, hull, 20.0)
    assert spanning(pts, planar_only) > 20
    inside = planar_only[np.all(planar_only < 180, axis=1) | np.all(planar_only >= 180, axis=1)]
    assert planar_area(pts, d.faces) == pytest.approx(planar_area(pts, inside), rel=1e-9)
    used = np.zeros(len(pts), dtype=bool)
    used[d.faces.ravel()] = True
    used[d.options["trimmed"]] = True
    assert used.all()
