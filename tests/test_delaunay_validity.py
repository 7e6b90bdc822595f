"""Delaunay faces are valid in the exact sense: every face strictly counter-clockwise in the
projection plane (rational arithmetic on the projected coordinates), no zero-area face,
and the face count of a triangulation of exactly the points (2n - h - 2)."""

from __future__ import annotations

import math
import warnings
from fractions import Fraction

import numpy as np
import pytest

import scanmesh
from scanmesh.scan.projection import project
from scanmesh.stages.optimal import optimal_surface


def exact_orient(a, b, c) -> Fraction:
    """Twice the signed area of planar triangle (a, b, c), in rationals (no rounding)."""
    ax, ay, bx, by, cx, cy = (Fraction(float(x)) for x in (*a, *b, *c))
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)


def non_ccw_faces(uv: np.ndarray, faces: np.ndarray) -> int:
    return sum(exact_orient(*uv[f]) <= 0 for f in faces)


def hull_boundary_count(uv: np.ndarray) -> int:
    """Points on the convex hull's boundary, collinear ones included (monotone chain in
    rationals, an implementation independent of the core's)."""
    pts = sorted({(Fraction(float(x)), Fraction(float(y))) for x, y in uv})

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    def chain(seq):
        out: list = []
        for p in seq:
            while len(out) >= 2 and cross(out[-2], out[-1], p) < 0:
                out.pop()
            out.append(p)
        return out

    lower, upper = chain(pts), chain(reversed(pts))
    return len(lower) + len(upper) - 2


def grid(n: int, height) -> np.ndarray:
    x, y = np.meshgrid(np.arange(n, dtype=float), np.arange(n, dtype=float))
    x, y = x.ravel(), y.ravel()
    return np.column_stack([x, y, height(x, y)])


HEIGHTS = {
    "flat": lambda x, y: 0 * x,
    "plane": lambda x, y: 3 * x - 2 * y,
    "saddle": lambda x, y: x * y,
    "steps": lambda x, y: (x * y) % 3,
}


@pytest.mark.parametrize("name", sorted(HEIGHTS))
@pytest.mark.parametrize("max_edge", [None, math.inf])
def test_exact_grid_faces_are_ccw_with_the_grid_count(name, max_edge):
    n = 10
    pts = grid(n, HEIGHTS[name])
    for plane in (None, "z"):
        s = scanmesh.delaunay(pts, plane=plane, max_edge=max_edge)
        uv, _ = project(pts, plane)
        assert non_ccw_faces(uv, s.faces) == 0, (name, plane)
        if plane == "z" or name in ("flat", "plane"):
            # The projection is an affine image of the grid: every cell split in two.
            assert len(s.faces) == 2 * (n - 1) ** 2, (name, plane, len(s.faces))
        used = np.zeros(len(pts), dtype=bool)
        used[s.faces.ravel()] = True
        used[s.options["trimmed"]] = True
        assert used.all()


def test_flat_grid_with_max_edge_inf_has_no_collinear_hull_slivers():
    n = 10
    pts = grid(n, HEIGHTS["flat"])
    s = scanmesh.delaunay(pts, max_edge=math.inf)
    uv, _ = project(pts)
    areas = [exact_orient(*uv[f]) for f in s.faces]
    assert min(areas) > 0
    assert len(s.faces) == 2 * (n - 1) ** 2


@pytest.mark.parametrize("seed", range(40))
def test_integer_points_triangulate_exactly(seed):
    """Small integer inputs (many collinear and cocircular points): strictly CCW faces,
    2n - h - 2 of them over the whole hull, covering exactly its area."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(5, 40))
    scale = 2.0 ** int(rng.integers(-900, 900))
    xy = rng.integers(-4, 5, (n, 2)).astype(float)
    pts = np.column_stack([xy, rng.integers(-2, 3, n)]) * scale
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", scanmesh.errors.CoincidentPointsWarning)
        try:
            s = scanmesh.delaunay(pts, plane="z", max_edge=math.inf)
        except scanmesh.errors.DegenerateInputError:
            assert len({tuple(p) for p in xy}) < 3 or np.linalg.matrix_rank(xy - xy[0]) < 2
            return
    uv, _ = project(pts, "z")
    assert non_ccw_faces(uv, s.faces) == 0
    distinct = len({tuple(p) for p in uv.tolist()})
    h = hull_boundary_count(uv)
    assert len(s.faces) == 2 * distinct - h - 2
    assert len(s.options["trimmed"]) == 0


@pytest.mark.parametrize("scale", [1e-300, 1e-150, 1e150, 1e300])
def test_optimal_at_extreme_scales_matches_unit_scale(scale):
    rng = np.random.default_rng(3)
    base = rng.random((10, 3))
    ref = optimal_surface(base, time_limit=30)
    got = optimal_surface(base * scale, time_limit=30)
    uv, _ = project(base * scale)
    assert len(got.faces) == len(ref.faces) > 0
    assert non_ccw_faces(uv, got.faces) == 0
    assert got.quality.tac_1 == pytest.approx(ref.quality.tac_1, rel=1e-9)
