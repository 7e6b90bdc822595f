"""Scan lines: detection from point order, explicit ids, segments at gaps."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

import scanmesh
from conftest import DATA
from scanmesh.formats import read_dem, read_vtk
from scanmesh.scan.lines import GAP_FACTOR, ScanLines, as_line_ids, scan_lines


def line_scan(
    rows: int,
    cols: int,
    *,
    zigzag: bool = False,
    across: float = 1.0,
    jitter: float = 0.0,
    drop: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
    seed: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """A line scan of the height field z = f(x, y): (points (N, 3), line ids (N,)).

    Lines run along x with unit point spacing and are stacked ``across`` apart along y;
    ``zigzag`` alternates their direction; ``jitter`` moves points in the plane; ``drop``
    removes the points where it is true (a hole) from every line.
    """
    rng = np.random.default_rng(seed)
    x = np.tile(np.arange(cols, dtype=float), (rows, 1))
    if zigzag:
        x[1::2] = x[1::2, ::-1]
    y = np.repeat(np.arange(rows, dtype=float) * across, cols).reshape(rows, cols)
    x = x + jitter * rng.uniform(-0.5, 0.5, x.shape)
    y = y + jitter * rng.uniform(-0.5, 0.5, y.shape)
    z = 0.8 * np.sin(0.3 * x) * np.cos(0.2 * y) + 0.02 * x
    ids = np.repeat(np.arange(rows), cols)
    points = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    if drop is not None:
        keep = ~drop(points[:, 0], points[:, 1])
        points, ids = points[keep], ids[keep]
    return points, ids


# Errors first.


def test_bad_line_ids_are_refused():
    pts, _ = line_scan(3, 5)
    with pytest.raises(scanmesh.ScanmeshError, match="one id per point"):
        as_line_ids(np.zeros(4), len(pts))
    with pytest.raises(scanmesh.ScanmeshError, match="non-integral"):
        as_line_ids(np.full(len(pts), 0.5), len(pts))
    with pytest.raises(scanmesh.ScanmeshError, match="integer"):
        as_line_ids(np.array(["a"] * len(pts)), len(pts))
    assert as_line_ids(np.ones(len(pts)), len(pts)).dtype == np.int64


@pytest.mark.parametrize("k", [0, -1, np.nan, np.inf])
def test_bad_gap_factor_is_refused(k):
    pts, _ = line_scan(3, 5)
    with pytest.raises(scanmesh.ParameterError, match="gap_factor"):
        scanmesh.detect_lines(pts, gap_factor=k)


def test_non_finite_points_are_refused():
    pts, _ = line_scan(3, 5)
    pts[4, 2] = np.nan
    with pytest.raises(scanmesh.DegenerateInputError):
        scanmesh.detect_lines(pts)


# Detection.


@pytest.mark.parametrize("zigzag", [False, True])
@pytest.mark.parametrize("across", [0.4, 1.0, 3.0, 12.0])
def test_raster_and_zigzag_scans_are_detected(zigzag, across):
    pts, ids = line_scan(9, 30, zigzag=zigzag, across=across, jitter=0.15, seed=1)
    found = scanmesh.detect_lines(pts, plane="z")
    assert found.dtype == np.int64
    np.testing.assert_array_equal(found, ids)


def test_a_hole_splits_lines_into_segments_but_not_into_lines():
    def hole(x, y):
        return (x - 15) ** 2 + (y - 4) ** 2 < 3.5**2

    pts, ids = line_scan(9, 30, zigzag=True, drop=hole)
    np.testing.assert_array_equal(scanmesh.detect_lines(pts, plane="z"), ids)
    lines = scan_lines(pts, plane="z")
    assert isinstance(lines, ScanLines)
    assert lines.n_lines == 9
    # A line loses the points inside the circle; the step over them is a gap (two
    # segments) when it is longer than GAP_FACTOR median steps.
    x = np.arange(30.0)
    missing = [int(hole(x, y).sum()) for y in range(9)]
    expected = [2 if m + 1 > GAP_FACTOR else 1 for m in missing]
    assert [len(line) for line in lines.lines] == expected
    assert expected.count(2) >= 5 and expected.count(1) >= 2  # both cases are exercised
    assert lines.median_step == pytest.approx(1.0)
    assert lines.gap == pytest.approx(GAP_FACTOR)
    # Segments keep scan order and cover every point exactly once.
    everything = np.concatenate([s for line in lines.lines for s in line])
    np.testing.assert_array_equal(np.sort(everything), np.arange(len(pts)))


def test_explicit_ids_are_grouped_by_ascending_id_in_input_order():
    pts, ids = line_scan(4, 6)
    order = np.random.default_rng(3).permutation(len(pts))
    shuffled_ids = ids[order] * 10 - 7  # any integers, any order
    lines = scan_lines(pts[order], shuffled_ids, plane="z")
    assert lines.n_lines == 4
    for line, expected_id in zip(lines.lines, sorted(set(shuffled_ids)), strict=True):
        (segment,) = line
        members = np.flatnonzero(shuffled_ids == expected_id)
        np.testing.assert_array_equal(segment, members)  # input order inside a line


def test_repeated_points_are_dropped_as_duplicates():
    pts, ids = line_scan(3, 6)
    pts = np.insert(pts, 4, pts[3], axis=0)
    ids = np.insert(ids, 4, ids[3])
    lines = scan_lines(pts, ids, plane="z")
    np.testing.assert_array_equal(lines.duplicates, [[4, 3]])
    assert 4 not in np.concatenate(lines.lines[0])


def test_lines_of_one_point_are_lines():
    pts = np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0], [1, 5, 0], [0, 9, 0], [1, 9, 0]])
    lines = scan_lines(pts, [0, 0, 0, 1, 2, 2], plane="z")
    assert [len(s) for line in lines.lines for s in line] == [3, 1, 2]


def test_real_scans_are_detected_as_their_files_say():
    fran = read_vtk(DATA / "scans" / "fran_cut.vtk")
    found = scanmesh.detect_lines(fran.points)
    np.testing.assert_array_equal(found, fran.line_ids)
    assert found.max() == 44
    dem = read_dem(DATA / "terrain" / "SainteHelens.dem")
    found = scanmesh.detect_lines(dem.points)
    np.testing.assert_array_equal(found, dem.line_ids)
    counts = np.bincount(found)
    assert len(counts) == 327 and counts.min() == 8 and counts.max() == 464


def test_the_rod_scan_with_its_bores_is_detected(rod_scan):
    points, line_ids = rod_scan
    np.testing.assert_array_equal(scanmesh.detect_lines(points), line_ids)
    lines = scan_lines(points, line_ids)
    # Rays through the bores and past the outline are missing: many lines have gaps.
    assert lines.n_segments > lines.n_lines + 100
