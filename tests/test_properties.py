"""Property tests (hypothesis) of the public API over awkward point sets: duplicates,
collinear runs, regular grids (cocircular cells), clusters, scales from 1e-300 to 1e300.

For every set: no panic (only ScanmeshError refusals), the mesh validates in its plane,
every input point is a face vertex, a reported duplicate or reported trimmed/unused, annealed
and LOP meshes keep the start's vertices, and strip meshes of clean scans validate.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import scanmesh
from scanmesh import DegenerateInputError, ScanmeshError, _core
from test_robustness import assert_accounted_for, planar_uv

SETTINGS = settings(
    max_examples=40,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow],
)

KINDS = ("random", "duplicates", "collinear-run", "grid", "clusters")
SCALES = (1.0, 1e-300, 1e-9, 1e9, 1e300)


def make_points(kind: str, n: int, seed: int, scale: float) -> np.ndarray:
    """(n, 3) height-field points whose planar positions are of the given kind."""
    rng = np.random.default_rng(seed)
    if kind == "random":
        xy = rng.random((n, 2))
    elif kind == "duplicates":
        xy = rng.random((n, 2))
        k = rng.integers(0, n, size=n // 3)
        xy[rng.integers(0, n, size=n // 3)] = xy[k] + rng.choice([0.0, 1e-12], size=(len(k), 1))
    elif kind == "collinear-run":
        t = np.linspace(0, 1, max(n - 3, 1))
        xy = np.vstack([np.column_stack([t, 0.3 + 0.4 * t]), rng.random((3, 2))])
    elif kind == "grid":
        side = max(int(np.ceil(np.sqrt(n))), 2)
        k = np.arange(max(n, 4))
        xy = np.column_stack([k % side, k // side]) * 0.1
    else:
        centres = rng.random((3, 2))
        xy = centres[rng.integers(0, 3, size=n)] + 1e-4 * rng.random((n, 2))
    z = 0.3 * np.sin(6 * xy[:, 0]) * np.cos(4 * xy[:, 1]) + 0.2 * xy[:, 0] ** 2
    return np.column_stack([xy, z]) * scale


point_sets = st.builds(
    make_points,
    st.sampled_from(KINDS),
    st.integers(3, 80),
    st.integers(0, 2**32 - 1),
    st.sampled_from(SCALES),
)


def quietly(fn, *args, **kwargs):
    """fn(...) with scanmesh's warnings silenced; a refusal must be a DegenerateInputError."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", scanmesh.ScanmeshWarning)
        try:
            return fn(*args, **kwargs)
        except DegenerateInputError:
            return None
        except ScanmeshError as exc:  # another refusal of valid-looking input is a bug
            pytest.fail(f"unexpected {type(exc).__name__}: {exc}")


@SETTINGS
@given(points=point_sets)
def test_delaunay_is_valid_and_loses_no_point(points):
    surface = quietly(scanmesh.delaunay, points, plane="z")
    if surface is None:
        return
    _core.validate(planar_uv(surface), surface.faces)
    assert_accounted_for(surface)
    hull = quietly(scanmesh.delaunay, points, plane="z", max_edge=np.inf)
    assert len(hull.options["trimmed"]) == 0
    # untrimmed: every point is a vertex or a duplicate
    assert len(np.unique(hull.faces)) + len(hull.duplicates) == len(points)


@pytest.mark.slow
@SETTINGS
@given(points=point_sets, p=st.sampled_from([1.0, 2.0]))
def test_lop_and_annealing_keep_valid_meshes_and_their_vertices(points, p):
    start = quietly(scanmesh.delaunay, points, plane="z")
    if start is None:
        return
    for method, options in (("lop", {"p": p}), ("anneal", {"p": p, "sweeps": 3})):
        surface = quietly(scanmesh.reconstruct, points, method, plane="z", **options)
        _core.validate(planar_uv(surface), surface.faces)
        assert_accounted_for(surface)
        np.testing.assert_array_equal(np.unique(surface.faces), np.unique(start.faces))


@st.composite
def scans(draw):
    """Clean scans: lines of unequal length along x, jittered along x only, some points
    repeated, a zig-zag or raster order, at any scale."""
    rows = draw(st.integers(2, 6))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    zigzag = draw(st.booleans())
    pts, ids = [], []
    for r in range(rows):
        n = int(rng.integers(2, 14))
        x = np.arange(n) + draw(st.sampled_from([0.0, 0.2])) * (rng.random(n) - 0.5)
        if zigzag and r % 2:
            x = x[::-1]
        y = np.full(n, 1.3 * r)
        pts.append(np.column_stack([x, y, 0.2 * np.sin(x / 3) * np.cos(y / 2)]))
        ids.append(np.full(n, r))
    pts, ids = np.vstack(pts), np.concatenate(ids)
    repeat = rng.integers(0, len(pts), size=draw(st.integers(0, 3)))
    pts = np.insert(pts, repeat + 1, pts[repeat], axis=0)
    ids = np.insert(ids, repeat + 1, ids[repeat])
    return pts * draw(st.sampled_from(SCALES)), ids


@SETTINGS
@given(
    scan=scans(), method=st.sampled_from(["shortest-path", "lookahead"]), given_lines=st.booleans()
)
def test_strip_meshes_of_clean_scans_are_valid(scan, method, given_lines):
    pts, ids = scan
    surface = quietly(
        scanmesh.reconstruct, pts, method, plane="z", lines=ids if given_lines else None
    )
    if surface is None:
        return
    if given_lines:
        assert surface.options["planar_valid"]
    if surface.options["planar_valid"]:
        _core.validate(planar_uv(surface), surface.faces)
    assert_accounted_for(surface)


@pytest.mark.slow
@SETTINGS
@given(points=point_sets, solver=st.sampled_from(["banded", "dp", "dijkstra"]))
def test_strips_over_any_points_never_panic(points, solver):
    # arbitrary point sets are no scan: only refusals and warnings are allowed
    surface = quietly(scanmesh.reconstruct, points, "shortest-path", solver=solver)
    if surface is not None:
        assert_accounted_for(surface)
