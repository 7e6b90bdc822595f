"""The embedded data: the demo scan (the fandisk ``scanmesh demo`` reconstructs) and the
connecting rod's scan shipped inside the package, each with its part."""

from __future__ import annotations

import gzip
import hashlib
import io
from importlib import resources

import numpy as np
import pytest
import trimesh

import scanmesh
from conftest import DATA
from scanmesh.demo import (
    PART_FILE,
    PART_SCAN,
    PART_SHA256,
    SCAN_SETTINGS,
    TRUTH_FILE,
    TRUTH_SHA256,
    demo_part,
    load_demo,
    load_rod,
    rod_truth,
    scan_demo_part,
)

CONROD = DATA / "cad" / "conrod_slevin48_onshape.stl"
PACKAGE_DATA = resources.files("scanmesh.data")


@pytest.fixture(scope="module")
def rod():
    return load_rod()


def test_rod_has_about_the_papers_point_count(rod):
    points, line_ids = rod
    assert abs(len(points) - 14_339) <= 0.03 * 14_339
    assert points.shape == (len(points), 3) and points.dtype == np.float64
    assert line_ids.shape == (len(points),) and line_ids.dtype == np.int64
    assert np.all(np.isfinite(points))


def test_rod_lines_are_ordered(rod):
    points, line_ids = rod
    assert line_ids[0] == 0 and np.all(np.diff(line_ids) >= 0)
    assert np.array_equal(np.unique(line_ids), np.arange(line_ids.max() + 1))
    assert line_ids.max() + 1 > 100
    for line in np.unique(line_ids):
        row = points[line_ids == line]
        assert np.all(np.diff(row[:, 0]) > 0)  # along +x
        assert np.ptp(row[:, 2]) == 0.0  # one z per line


def test_rod_points_lie_on_the_truth(rod):
    points, _ = rod
    truth = rod_truth()
    _, dist, _ = trimesh.proximity.closest_point(truth, points)
    assert dist.max() < 1e-9
    # seen from +y: only the top face and the recessed web
    assert set(np.round(points[:, 1], 4)) == {0.1969, 0.3937}


def test_truth_is_the_connecting_rod():
    truth = rod_truth()
    assert isinstance(truth, trimesh.Trimesh)
    assert truth.vertices.shape == (524, 3) and truth.faces.shape == (1044, 3)
    assert truth.is_watertight
    np.testing.assert_allclose(truth.extents, [5.6088, 0.7874, 1.9685], atol=1e-3)


def test_shipped_stl_is_the_source_byte_for_byte():
    raw = gzip.decompress(PACKAGE_DATA.joinpath(TRUTH_FILE).read_bytes())
    assert hashlib.sha256(raw).hexdigest() == TRUTH_SHA256
    assert raw == CONROD.read_bytes()


def test_rod_regenerates_from_the_source(rod):
    points, line_ids = scanmesh.simulate_scan(CONROD, **SCAN_SETTINGS)
    np.testing.assert_array_equal(points, rod[0])
    np.testing.assert_array_equal(line_ids, rod[1])


def test_attribution_names_source_licence_and_settings():
    text = PACKAGE_DATA.joinpath("ATTRIBUTION.md").read_text()
    for needed in ("slevin48/3d", "6c52a466", "MIT", TRUTH_SHA256, 'up="y"', "n_points=14339"):
        assert needed in text


def test_exported_from_the_package():
    assert scanmesh.load_demo is load_demo and scanmesh.load_rod is load_rod
    assert callable(scanmesh.simulate_scan)


def test_the_demo_part_is_the_fandisk_turned_about_y():
    raw = gzip.decompress(PACKAGE_DATA.joinpath(PART_FILE).read_bytes())
    assert hashlib.sha256(raw).hexdigest() == PART_SHA256
    plain = trimesh.load_mesh(io.BytesIO(raw), file_type="obj")
    part = demo_part()
    assert len(part.vertices) == len(plain.vertices) == 2877
    # turned about y through the centroid: y and the centroid kept, x and z changed
    np.testing.assert_allclose(part.vertices[:, 1], plain.vertices[:, 1], atol=1e-12)
    np.testing.assert_allclose(part.centroid, plain.centroid, atol=1e-9)
    turned = np.radians(PART_SCAN["turn_deg"])
    moved = part.vertices[:, [0, 2]] - part.centroid[[0, 2]]
    before = plain.vertices[:, [0, 2]] - plain.centroid[[0, 2]]
    angles = np.arctan2(moved[:, 1], moved[:, 0]) - np.arctan2(before[:, 1], before[:, 0])
    far = np.linalg.norm(before, axis=1) > 0.1
    assert np.allclose(np.abs(np.angle(np.exp(1j * angles[far]))), turned, atol=1e-9)


def test_the_demo_scan_is_seeded_and_lies_on_the_part_within_its_noise():
    part = demo_part()
    points, line_ids, spacing = scan_demo_part(part)
    again, again_ids, _ = scan_demo_part(part)
    np.testing.assert_array_equal(points, again)
    np.testing.assert_array_equal(line_ids, again_ids)
    assert 8_000 < len(points) < 12_000
    sigma = PART_SCAN["noise"] * spacing
    _, distance, _ = trimesh.proximity.closest_point(part, points[::10])
    assert np.sqrt(np.mean(distance**2)) < 2 * sigma
    assert distance.max() < 6 * sigma


def test_load_demo_is_the_scan_the_demo_command_reconstructs():
    """One name for one thing: ``load_demo()`` is the fandisk scan of ``scanmesh demo``
    (not the rod), and its part is :func:`demo_part`."""
    points, line_ids = load_demo()
    scanned, scanned_ids, _ = scan_demo_part()
    np.testing.assert_array_equal(points, scanned)
    np.testing.assert_array_equal(line_ids, scanned_ids)
    assert points.dtype == np.float64 and line_ids.dtype == np.int64
    rod_points, _ = load_rod()
    assert len(points) != len(rod_points)


def test_the_demo_scan_is_curved_where_the_rod_is_flat(rod):
    """The tour's scan gives the methods something to differ on: Delaunay's mesh of the
    demo scan has tac well above zero and annealing lowers it, where on the rod (flat where
    scanned) both are zero."""
    points, line_ids = load_demo()
    base = scanmesh.reconstruct(points, "delaunay", plane="y")
    annealed = scanmesh.reconstruct(base.scan, "anneal", initial=base, seed=0)
    assert base.quality.tac_1 > 10.0
    assert annealed.quality.tac_1 < 0.5 * base.quality.tac_1
    flat = scanmesh.reconstruct(rod[0], "delaunay", plane="y")
    assert flat.quality.tac_1 < 1e-6
