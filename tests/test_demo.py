"""The embedded demo: a scan of the connecting rod shipped inside the package, and its truth."""

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
    demo_truth,
    load_demo,
    scan_demo_part,
)

CONROD = DATA / "cad" / "conrod_slevin48_onshape.stl"
PACKAGE_DATA = resources.files("scanmesh.data")


@pytest.fixture(scope="module")
def demo():
    return load_demo()


def test_demo_has_about_the_papers_point_count(demo):
    points, line_ids = demo
    assert abs(len(points) - 14_339) <= 0.03 * 14_339
    assert points.shape == (len(points), 3) and points.dtype == np.float64
    assert line_ids.shape == (len(points),) and line_ids.dtype == np.int64
    assert np.all(np.isfinite(points))


def test_demo_lines_are_ordered(demo):
    points, line_ids = demo
    assert line_ids[0] == 0 and np.all(np.diff(line_ids) >= 0)
    assert np.array_equal(np.unique(line_ids), np.arange(line_ids.max() + 1))
    assert line_ids.max() + 1 > 100
    for line in np.unique(line_ids):
        row = points[line_ids == line]
        assert np.all(np.diff(row[:, 0]) > 0)  # along +x
        assert np.ptp(row[:, 2]) == 0.0  # one z per line


def test_demo_points_lie_on_the_truth(demo):
    points, _ = demo
    truth = demo_truth()
    _, dist, _ = trimesh.proximity.closest_point(truth, points)
    assert dist.max() < 1e-9
    # seen from +y: only the top face and the recessed web
    assert set(np.round(points[:, 1], 4)) == {0.1969, 0.3937}


def test_truth_is_the_connecting_rod():
    truth = demo_truth()
    assert isinstance(truth, trimesh.Trimesh)
    assert truth.vertices.shape == (524, 3) and truth.faces.shape == (1044, 3)
    assert truth.is_watertight
    np.testing.assert_allclose(truth.extents, [5.6088, 0.7874, 1.9685], atol=1e-3)


def test_shipped_stl_is_the_source_byte_for_byte():
    raw = gzip.decompress(PACKAGE_DATA.joinpath(TRUTH_FILE).read_bytes())
    assert hashlib.sha256(raw).hexdigest() == TRUTH_SHA256
    assert raw == CONROD.read_bytes()


def test_demo_regenerates_from_the_source(demo):
    points, line_ids = scanmesh.simulate_scan(CONROD, **SCAN_SETTINGS)
    np.testing.assert_array_equal(points, demo[0])
    np.testing.assert_array_equal(line_ids, demo[1])


def test_attribution_names_source_licence_and_settings():
    text = PACKAGE_DATA.joinpath("ATTRIBUTION.md").read_text()
    for needed in ("slevin48/3d", "6c52a466", "MIT", TRUTH_SHA256, 'up="y"', "n_points=14339"):
        assert needed in text


def test_exported_from_the_package():
    assert scanmesh.load_demo is load_demo
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
