"""Strip reconstruction: Fuchs-matrix paths between consecutive lines, stitched into a mesh."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
import scipy.spatial

import scanmesh
from conftest import DATA
from scanmesh import _core
from scanmesh.formats import read_dem, read_vtk
from scanmesh.stages.strips import (
    CRITERIA,
    DEFAULT_WEIGHT,
    CrossingLinesWarning,
    UnusedPointsWarning,
    strip_surface,
)
from test_lines import line_scan

ALL_WEIGHTS = [*CRITERIA, DEFAULT_WEIGHT]


def quiet(points, **kwargs) -> scanmesh.Surface:
    """strip_surface with warnings turned into errors: the input is supposed to be clean."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return strip_surface(points, **kwargs)


def planar_uv(surface: scanmesh.Surface) -> np.ndarray:
    """The surface's points in its projection plane, (N, 2)."""
    uv, _ = scanmesh.project(surface.vertices, surface.options["plane"])
    return uv


def contains(surface: scanmesh.Surface, q: np.ndarray) -> np.ndarray:
    """(M,) bool: which faces hold point q = (x, y) strictly inside, seen along z (the faces
    are counter-clockwise there when the surface was built with ``plane="z"``)."""
    xy, faces = surface.vertices[:, :2], surface.faces
    a, b, c = (xy[faces[:, k]] for k in range(3))

    def left(p, r):
        return (r[:, 0] - p[:, 0]) * (q[1] - p[:, 1]) - (r[:, 1] - p[:, 1]) * (q[0] - p[:, 0]) > 0

    return left(a, b) & left(b, c) & left(c, a)


def assert_manifold_disc_like(surface: scanmesh.Surface) -> None:
    """Consistently oriented, every edge in one or two faces, no repeated faces."""
    mesh = surface.to_trimesh()
    assert mesh.is_winding_consistent
    edges = np.sort(mesh.edges, axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert counts.max() <= 2
    assert len(np.unique(np.sort(surface.faces, axis=1), axis=0)) == len(surface.faces)
    assert mesh.area_faces.min() > 0


# Errors first.


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"method": "greedy"}, "method"),
        ({"weight": "curvature"}, "weight"),
        ({"weight": {"angle": 1, "bogus": 2}}, "bogus"),
        ({"weight": {"angle": -1}}, "non|>= 0"),
        ({"weight": {"angle": 0}}, "positive"),
        ({"weight": 3}, "weight"),
        ({"alpha": 0, "method": "lookahead"}, "alpha"),
        ({"alpha": 1.5}, "alpha"),
        ({"solver": "astar"}, "solver"),
        ({"band": 0}, "band"),
        ({"gap_factor": 0}, "gap_factor"),
        ({"jump_factor": 0}, "jump_factor"),
        ({"jump_factor": -1.0}, "jump_factor"),
        ({"jump_factor": float("nan")}, "jump_factor"),
    ],
)
def test_bad_options_are_refused(kwargs, match):
    pts, ids = line_scan(4, 8)
    with pytest.raises(scanmesh.ParameterError, match=match):
        strip_surface(pts, lines=ids, **kwargs)


def test_strips_too_large_for_their_solver_are_refused_before_the_work():
    pts, ids = line_scan(2, 20_000)
    # Dijkstra keeps 9 bytes for each of the 2 x 20,000^2 states: 7.2 GB.
    with pytest.raises(scanmesh.ParameterError, match=r"solver='dijkstra' on .* GB"):
        strip_surface(pts, lines=ids, plane="z", solver="dijkstra")
    pts, ids = line_scan(2, 1_500)
    with pytest.raises(scanmesh.ParameterError, match=r"alpha=1000 on .*window cells"):
        strip_surface(pts, lines=ids, plane="z", method="lookahead", alpha=1000)


@pytest.mark.parametrize("alpha", [10**9, 2**64, 10**30])
def test_a_lookahead_deeper_than_every_strip_is_the_shortest_path(alpha):
    pts, ids = line_scan(3, 300, jitter=0.3, seed=5)
    best = quiet(pts, lines=ids, plane="z", solver="dp").options["cost"]
    look = quiet(pts, lines=ids, plane="z", method="lookahead", alpha=alpha)
    assert look.options["cost"] == pytest.approx(best, rel=1e-12)
    assert look.options["alpha"] == alpha


def test_bad_lines_and_points_are_refused():
    pts, ids = line_scan(4, 8)
    with pytest.raises(scanmesh.ScanmeshError, match="one id per point"):
        strip_surface(pts, lines=ids[:-1])
    bad = pts.copy()
    bad[5, 0] = np.inf
    with pytest.raises(scanmesh.DegenerateInputError):
        strip_surface(bad, lines=ids)
    with pytest.raises(scanmesh.DegenerateInputError, match="no strip"):
        strip_surface(pts[:8], lines=ids[:8])  # a single line


# Synthetic scans.


@pytest.mark.parametrize("weight", ALL_WEIGHTS, ids=str)
@pytest.mark.parametrize("method", ["shortest-path", "lookahead"])
@pytest.mark.parametrize("zigzag", [False, True])
def test_a_clean_scan_is_a_valid_mesh_of_every_point(weight, method, zigzag):
    pts, ids = line_scan(8, 25, zigzag=zigzag, jitter=0.2, seed=2)
    for lines in (ids, None):
        surface = quiet(pts, lines=lines, weight=weight, method=method, plane="z")
        # (L - 1) strips of n + m - 2 triangles each.
        assert len(surface.faces) == 7 * (25 + 25 - 2)
        _core.validate(planar_uv(surface), surface.faces)  # CCW in the plane, no folds
        assert len(np.unique(surface.faces)) == len(pts)
        assert surface.method == method
        assert surface.options["n_strips"] == 7 and surface.options["planar_valid"]
        assert surface.options["lines"] == ("given" if lines is not None else "detected")
        assert set(surface.timings) == {"project", "lines", "strips"}


def test_a_hole_across_several_lines_stays_open():
    centre, radius = np.array([15.0, 5.0]), 3.2

    def hole(x, y):
        return np.hypot(x - centre[0], y - centre[1]) < radius

    pts, ids = line_scan(11, 30, zigzag=True, drop=hole)
    probes = centre + np.array([[0, 0], [1.5, 0.5], [-1.5, -0.5], [0.5, 1.8], [-0.4, -1.9]])
    for weight in ALL_WEIGHTS:
        for method in ("shortest-path", "lookahead"):
            surface = quiet(pts, lines=ids, weight=weight, method=method, plane="z")
            _core.validate(planar_uv(surface), surface.faces)
            assert contains(surface, np.array([3.3, 2.4])).sum() == 1  # the probe works
            for q in probes:
                assert not contains(surface, q).any(), f"{weight} {method}: {q}"
            # Every point is in a face or trimmed (lookahead's fans of 10-27 spacings along
            # the rim under the area and dihedral weights bridge it: the gap rule drops them).
            used = np.unique(np.concatenate([surface.faces.ravel(), surface.options["trimmed"]]))
            assert len(used) == len(pts)
            if surface.options["dropped_jumps"] == 0:
                # One hole: two boundary loops, so V - E + F = 0 (a disc would give 1).
                mesh = surface.to_trimesh()
                assert len(pts) - len(mesh.edges_unique) + len(mesh.faces) == 0


def test_without_the_gap_rule_the_hole_would_be_covered():
    """The hole test can fail: with a gap factor wider than the hole (and the depth-jump
    rule off, ``jump_factor=inf``), strips bridge it."""
    pts, ids = line_scan(11, 30, drop=lambda x, y: np.hypot(x - 15, y - 5) < 3.2)
    surface = quiet(pts, lines=ids, plane="z", gap_factor=20.0, jump_factor=math.inf)
    assert contains(surface, np.array([14.2, 5.3])).any()


def test_lines_of_unequal_length_use_every_point():
    # A parallelogram cut into lines: each line starts and ends a little later than the
    # one before, and the lines have 22 to 34 points.
    pts, ids = line_scan(12, 60, drop=lambda x, y: (x < 0.6 * y) | (x > 22 + 1.8 * y), seed=4)
    counts = np.bincount(ids)
    assert counts.min() < counts.max()
    for method in ("shortest-path", "lookahead"):
        surface = quiet(pts, lines=ids, method=method, plane="z")
        _core.validate(planar_uv(surface), surface.faces)
        assert len(np.unique(surface.faces)) == len(pts)


def test_a_one_point_line_is_inserted():
    pts, ids = line_scan(4, 12)
    lone = np.array([[5.3, 1.5, 0.0]])
    pts = np.vstack([pts, lone])
    ids = np.concatenate([np.where(ids >= 2, ids + 1, ids), [2]])
    surface = quiet(pts, lines=ids, plane="z")
    _core.validate(planar_uv(surface), surface.faces)
    assert len(pts) - 1 in surface.faces
    assert len(surface.faces) == 3 * (12 + 12 - 2) + 2  # a triangle split into three


def test_an_isolated_point_outside_every_strip_is_reported():
    pts, ids = line_scan(4, 12)
    pts = np.vstack([pts, [[40.0, 1.5, 0.0]]])
    ids = np.concatenate([np.where(ids >= 2, ids + 1, ids), [2]])
    with pytest.warns(UnusedPointsWarning, match="1 point"):
        surface = strip_surface(pts, lines=ids, plane="z")
    np.testing.assert_array_equal(surface.options["unused"], [len(pts) - 1])


def overlapping_faces(uv: np.ndarray, faces: np.ndarray) -> int:
    """Brute force, independent of the core: pairs of faces whose interiors overlap in the
    plane (no edge of either has all corners of the other on or outside its line, with a
    tolerance against rounding), plus faces that are not counter-clockwise."""
    corners = uv[faces]  # (M, 3, 2)

    def cross(u: np.ndarray, v: np.ndarray) -> np.ndarray:
        return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]

    area = cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    scale = np.abs(uv).max()
    tol = 1e-12 * scale * scale

    def separated(p: np.ndarray, q: np.ndarray) -> np.ndarray:
        # [i, j]: an edge of face i leaves every corner of face j on or right of its line.
        e0, e1 = p[:, None, :, None, :], np.roll(p, -1, axis=1)[:, None, :, None, :]
        r = q[None, :, None, :, :]
        side = cross(e1 - e0, r - e0)  # (M, M, 3 edges, 3 corners)
        return (side <= tol).all(axis=3).any(axis=2)

    sep = separated(corners, corners)
    overlap = ~(sep | sep.T)
    np.fill_diagonal(overlap, False)
    return int(np.count_nonzero(np.triu(overlap))) + int(np.count_nonzero(area <= 0))


def test_the_overlap_check_sees_crossing_strips():
    # The fixture of the tests below, stitched without the planar check: it overlaps.
    pts, ids = crossing_scan()
    surface = quiet(pts, lines=ids, plane="z", check=False)
    assert surface.options["planar_valid"] is None and surface.options["dropped_overlaps"] == 0
    assert overlapping_faces(pts[:, :2], surface.faces) > 0
    assert len(surface.faces) == 2 * 22


def crossing_scan() -> tuple[np.ndarray, np.ndarray]:
    """Three lines of 12 points; the third crosses the second at x = 10/3."""
    pts, ids = line_scan(3, 12)
    third = ids == 2
    pts[third, 1] = 2.0 - 0.3 * pts[third, 0]
    return pts, ids


def overlapping_passes() -> tuple[np.ndarray, np.ndarray]:
    """A zig-zag scan in two passes over the same ground, the second half a line spacing
    off the first: the strip from the last line of pass one to the first of pass two spans
    the whole area, and pass two's lines lie between pass one's."""
    pts, ids = line_scan(6, 15, zigzag=True, jitter=0.1, seed=3)
    again = pts.copy()
    again[:, 1] += 0.5
    again[:, 2] = np.sin(0.4 * again[:, 0]) * np.cos(0.3 * again[:, 1])
    return np.vstack([pts, again]), np.concatenate([ids, ids + 6])


@pytest.mark.parametrize("method", ["shortest-path", "lookahead"])
@pytest.mark.parametrize("scan", [crossing_scan, overlapping_passes])
def test_crossing_lines_give_a_manifold_valid_mesh_and_say_what_was_dropped(method, scan):
    pts, ids = scan()
    # The repair alone: lookahead's fans where lines cross are long enough for the gap rule
    # (jump_factor), which would drop them before the repair sees them.
    off = {"jump_factor": math.inf}
    with pytest.warns(CrossingLinesWarning, match=r"(\d+) of (\d+) strip triangles") as record:
        surface = strip_surface(pts, lines=ids, plane="z", method=method, **off)
    dropped = surface.options["dropped_overlaps"]
    assert dropped > 0 and surface.options["planar_valid"]
    message = str(next(w.message for w in record if w.category is CrossingLinesWarning))
    assert f"{dropped} of {len(surface.faces) + dropped} strip triangles" in message
    _core.validate(pts[:, :2].copy(), surface.faces)  # planar: CCW, no overlap, one fan
    assert overlapping_faces(pts[:, :2], surface.faces) == 0  # and by brute force
    assert_manifold_disc_like(surface)  # trimesh: 3-D manifold, consistent winding
    # Only what overlapped went: the unchecked strips minus the drops.
    unchecked = strip_surface(pts, lines=ids, plane="z", method=method, check=False, **off)
    kept = {tuple(sorted(f)) for f in surface.faces.tolist()}
    assert kept <= {tuple(sorted(f)) for f in unchecked.faces.tolist()}
    assert len(unchecked.faces) - len(surface.faces) == dropped
    # Points that lost every triangle to the drops are trimmed, not unused by the strips.
    np.testing.assert_array_equal(surface.options["trimmed"], surface.options["unused"])
    lost = np.setdiff1d(np.unique(unchecked.faces), np.unique(surface.faces))
    np.testing.assert_array_equal(surface.options["trimmed"], lost)


def test_crossing_lines_keep_the_strips_that_do_not_overlap():
    pts, ids = crossing_scan()
    with pytest.warns(CrossingLinesWarning):
        surface = strip_surface(pts, lines=ids, plane="z")
    # The strip between lines 0 and 1 does not overlap anything: all 22 triangles stay.
    first = np.isin(surface.faces, np.flatnonzero(ids <= 1)).all(axis=1)
    assert np.count_nonzero(first) == 22
    assert 0 < surface.options["dropped_overlaps"] < 22


@pytest.mark.slow
def test_shortest_path_is_never_above_lookahead_on_real_strips(rod_scan):
    fran = read_vtk(DATA / "scans" / "fran_cut.vtk")
    scans = {"rod": rod_scan, "fran": (fran.points, fran.line_ids)}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", CrossingLinesWarning)  # fran folds in any plane
        for name, (points, line_ids) in scans.items():
            for weight in ALL_WEIGHTS:
                best = strip_surface(points, lines=line_ids, weight=weight).options["cost"]
                for alpha in range(1, 7):
                    look = strip_surface(
                        points, lines=line_ids, weight=weight, method="lookahead", alpha=alpha
                    ).options["cost"]
                    assert best <= look * (1 + 1e-12), f"{name} {weight} alpha={alpha}"


@pytest.mark.slow
def test_every_solver_finds_the_same_optimum_on_real_strips(rod_scan):
    points, line_ids = rod_scan
    for weight in ALL_WEIGHTS:
        costs = [
            strip_surface(points, lines=line_ids, weight=weight, solver=s).options["cost"]
            for s in ("banded", "dp", "dijkstra")
        ]
        np.testing.assert_allclose(costs, costs[1], rtol=1e-9, err_msg=str(weight))


# Real scans.


def test_fran_cut_is_a_manifold_mesh_valid_in_its_plane():
    fran = read_vtk(DATA / "scans" / "fran_cut.vtk")
    points = fran.points
    # A cylindrical scan over 93 degrees folds in every projection plane: the folded
    # triangles are dropped and said so (4.4 % in the plane chosen by the data), and what
    # stays is manifold and valid in that plane.
    with pytest.warns(CrossingLinesWarning, match="186 of 4206"):
        surface = strip_surface(points)
    assert surface.options["n_lines"] == 45
    assert surface.options["planar_valid"] and surface.options["dropped_overlaps"] == 186
    assert len(surface.faces) + 186 == 4206  # 44 strips of 96, less 6 duplicate points
    _core.validate(surface.scan.uv, surface.faces)
    assert_manifold_disc_like(surface)
    assert len(np.unique(surface.faces)) == len(points) - len(surface.options["unused"]) > 2100
    # In the scan's own coordinates (azimuth about the y axis, height y) the strips were a
    # valid planar triangulation; what stays of them still is.
    azimuth = np.arctan2(points[:, 0], -points[:, 2])
    _core.validate(np.ascontiguousarray(np.column_stack([-azimuth, points[:, 1]])), surface.faces)
    assert surface.quality.min_angle_deg > 10


@pytest.mark.slow
def test_sainte_helens_is_a_valid_mesh_of_every_point():
    dem = read_dem(DATA / "terrain" / "SainteHelens.dem")
    surface = quiet(dem.points, lines=dem.line_ids)
    assert len(np.unique(surface.faces)) == len(dem.points) == 148_885
    _core.validate(planar_uv(surface), surface.faces)
    assert_manifold_disc_like(surface)
    # Profiles of 8 to 464 points (the quadrangle is rotated against the UTM grid): the
    # strips cover the whole quadrangle, one disc without holes, up to its outline.
    mesh = surface.to_trimesh()
    assert len(dem.points) - len(mesh.edges_unique) + len(mesh.faces) == 1
    xy = dem.points[:, :2]
    a, b, c = (xy[surface.faces[:, k]] for k in range(3))
    u, v = b - a, c - a
    area = 0.5 * np.abs(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]).sum()
    hull = scipy.spatial.ConvexHull(xy).volume
    assert 0.99 * hull < area <= hull * (1 + 1e-9)
    assert np.isfinite(surface.quality.tac_1) and surface.quality.min_angle_deg > 1


def test_points_collinear_in_the_plane_make_no_zero_area_strip_triangle():
    """Three of these integer points lie on x + y = 3 in the plane z: the strips' planar
    check must see them exactly collinear (the mesh it accepts passes validate) instead of
    rounding them apart (found by the API fuzz, case 47711)."""
    from scanmesh import _core

    points = np.array([[3, 0, -1], [1, 2, 2], [2, 1, 1], [3, 3, -1], [1, 3, 0]], dtype=np.float64)
    surface = scanmesh.reconstruct(points, "shortest-path", plane=(0.0, 0.0, 1.0))
    assert surface.options["planar_valid"]
    _core.validate(surface.scan.uv, surface.faces)  # raises on a flat or clockwise face


#: Strips of a scan with a wall (so lines are cut at jumps and bridging triangles dropped)
#: and crossing lines, in a fresh process: faces, drops and projection by method.
_THREADS_SCRIPT = """
import hashlib, json, warnings
import numpy as np
import scanmesh
rng = np.random.default_rng(3)
lines, per = 120, 150
x = np.tile(np.arange(per, dtype=float), lines) + rng.uniform(-0.1, 0.1, lines * per)
y = np.repeat(np.arange(lines, dtype=float), per) + rng.uniform(-0.1, 0.1, lines * per)
z = 0.2 * np.sin(x / 9) + np.where(x > 70.5, 15.0, 0.0) + np.where(y > 80.5, 9.0, 0.0)
points = np.column_stack([x, y, z])
ids = np.repeat(np.arange(lines), per)
out = {}
warnings.simplefilter("ignore")
for method, options in [("shortest-path", {}), ("lookahead", {"alpha": 1})]:
    s = scanmesh.reconstruct(points, method, lines=ids, **options)
    out[method] = [
        hashlib.sha1(s.faces.tobytes()).hexdigest(),
        s.options["dropped_jumps"],
        hashlib.sha1(s.scan.uv.tobytes()).hexdigest(),
    ]
print(json.dumps(out))
"""


@pytest.mark.slow
def test_strips_do_not_depend_on_the_thread_count():
    import json
    import os
    import subprocess
    import sys

    runs = []
    for threads in ("1", "2"):
        env = {**os.environ, "RAYON_NUM_THREADS": threads}
        done = subprocess.run(
            [sys.executable, "-c", _THREADS_SCRIPT], env=env, capture_output=True, text=True
        )
        assert done.returncode == 0, done.stderr
        runs.append(json.loads(done.stdout))
    assert runs[0] == runs[1]
    # The scan exercises the depth-jump rule (triangles dropped at the walls).
    assert all(dropped > 0 for _, dropped, _ in runs[0].values())


@pytest.mark.parametrize("jitter", [0.0, 0.3])
def test_filtered_walk_gives_the_exact_walks_faces_and_cost(jitter):
    """Look-ahead with alpha = 1 takes its decisions from cheap bounds (the core's
    ``filter``); turned off, every step is evaluated exactly: the same faces and cost."""
    pts, ids = line_scan(30, 40, jitter=jitter, seed=3)
    try:
        _core.set_strip_filter(False)
        _core.strip_filter_counts(reset=True)
        exact = scanmesh.reconstruct(pts, "lookahead", lines=ids, alpha=1)
        assert _core.strip_filter_counts() == (0, 0)
        _core.set_strip_filter(True)
        filtered = scanmesh.reconstruct(pts, "lookahead", lines=ids, alpha=1)
        decisions, fallbacks = _core.strip_filter_counts(reset=True)
    finally:
        _core.set_strip_filter(True)
    np.testing.assert_array_equal(filtered.faces, exact.faces)
    assert filtered.options["cost"] == exact.options["cost"]
    # One decision per step off the last row and column of each of the 29 strips.
    assert 29 * 30 <= decisions <= 29 * 78
    assert fallbacks <= decisions
