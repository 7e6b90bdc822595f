"""The embedded demo: a scan of the connecting rod shipped inside the package, and its truth."""

from __future__ import annotations

import gzip
import hashlib
from importlib import resources

import numpy as np
import pytest
import trimesh

import scanmesh
from conftest import DATA
from scanmesh.demo import SCAN_SETTINGS, TRUTH_FILE, TRUTH_SHA256, demo_truth, load_demo

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
