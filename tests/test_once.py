"""Computed once: the scan lines, their segments and the noise estimate are kept on the
PlanarScan, so no stage detects or estimates them again; and the spacing helpers take the
medians they say they take."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

import scanmesh
from scanmesh import _core
from scanmesh.cli import main
from scanmesh.scan import noise as noise_module
from scanmesh.scan import spacing
from scanmesh.scan.lines import GAP_FACTOR
from scanmesh.stages import options


def _scan_rows(n_lines: int = 30, per_line: int = 40, seed: int = 0) -> np.ndarray:
    """Points of a noisy height field in scan order: lines along x, stacked along y."""
    rng = np.random.default_rng(seed)
    x, y = np.meshgrid(np.arange(per_line, dtype=float), np.arange(n_lines, dtype=float))
    x = x + rng.uniform(-0.1, 0.1, x.shape)
    z = 2.0 * np.sin(x / 7) * np.cos(y / 5) + rng.normal(0.0, 0.02, x.shape)
    return np.column_stack([x.ravel(), y.ravel(), z.ravel()])


@pytest.fixture
def counted(monkeypatch):
    """Counts of the core's line detection and segmentation and of the noise estimate."""
    calls = {"detect_lines": 0, "scan_segments": 0, "noise": 0}

    def counting(name, target, attr):
        original = getattr(target, attr)

        def wrapper(*args, **kwargs):
            calls[name] += 1
            return original(*args, **kwargs)

        monkeypatch.setattr(target, attr, wrapper)

    counting("detect_lines", _core, "detect_lines")
    counting("scan_segments", _core, "scan_segments")
    counting("noise", noise_module, "_noise")
    return calls


def test_annealing_from_strips_detects_the_lines_once(counted):
    """Strips detect the lines, annealing's noise estimate segments the same ones (it
    detected them a second time before they were kept on the scan)."""
    pts = _scan_rows()
    surface = scanmesh.reconstruct(
        pts, "anneal", plane="z", initial="shortest-path", sweeps=2, tie_tolerance=None
    )
    assert counted == {"detect_lines": 1, "scan_segments": 1, "noise": 1}
    # the same estimate, bit for bit, as on a scan of its own
    assert surface.options["noise"] == scanmesh.noise(pts, plane="z")


def test_noise_then_strips_on_one_scan_detect_once(counted):
    scan = scanmesh.planar_scan(_scan_rows(), plane="z")
    sigma = scanmesh.noise(scan)
    strips = scanmesh.reconstruct(scan, "shortest-path")
    assert counted["detect_lines"] == 1
    assert strips.options["n_lines"] == len(np.unique(scanmesh.detect_lines(scan)))
    # asked again, the noise is the kept value: nothing is detected, segmented or estimated
    assert scanmesh.noise(scan) == sigma
    assert counted == {"detect_lines": 1, "scan_segments": 1, "noise": 1}


def test_two_annealing_runs_on_one_scan_estimate_the_noise_once(counted):
    scan = scanmesh.planar_scan(_scan_rows(), plane="z")
    first = scanmesh.reconstruct(scan, "anneal", sweeps=2, seed=1, tie_tolerance=None)
    second = scanmesh.reconstruct(scan, "anneal", sweeps=2, seed=2, tie_tolerance=None)
    assert first.options["noise"] == second.options["noise"]
    assert counted == {"detect_lines": 1, "scan_segments": 1, "noise": 1}


def test_another_gap_factor_is_detected_on_its_own(counted):
    """Lines depend on the gap factor: a scan keeps them per factor, never mixes them."""
    scan = scanmesh.planar_scan(_scan_rows(), plane="z")
    scanmesh.reconstruct(scan, "shortest-path", gap_factor=2.5)
    scanmesh.noise(scan)  # at the default factor
    assert GAP_FACTOR != 2.5
    assert counted["detect_lines"] == 2
    np.testing.assert_array_equal(
        scan.detected_line_ids(2.5), _core.detect_lines(np.asarray(scan.uv), 2.5)
    )


def test_kept_lines_are_read_only_and_detect_lines_returns_a_copy():
    scan = scanmesh.planar_scan(_scan_rows(), plane="z")
    ids = scanmesh.detect_lines(scan)
    ids[:] = -1  # the caller's copy
    kept = scan.line_ids_for(GAP_FACTOR)
    assert not kept.flags.writeable and kept.min() == 0
    segment = scan.lines(GAP_FACTOR).lines[0][0]
    assert not segment.flags.writeable


def test_info_detects_the_lines_once(counted, tmp_path, capsys):
    """``scanmesh info`` counts the lines and estimates the noise from one detection."""
    path = tmp_path / "rows.xyz"
    np.savetxt(path, _scan_rows())
    assert main(["info", str(path), "--plane", "z"]) == 0
    assert "detected from the point order" in capsys.readouterr().out
    assert counted == {"detect_lines": 1, "scan_segments": 1, "noise": 1}


# --------------------------------------------------------------------------- spacings


def test_one_trimming_factor():
    assert options.MAX_EDGE_FACTOR is spacing.MAX_EDGE_FACTOR
    assert spacing.MAX_EDGE_FACTOR == _core.DEFAULT_MAX_EDGE_FACTOR


@pytest.mark.parametrize("seed", range(4))
def test_spacing_helpers_against_numpy(seed):
    rng = np.random.default_rng(seed)
    uv = rng.random((2 * rng.integers(200, 400) + 1, 2))  # an odd count: one middle value
    faces, _ = _core.delaunay(uv)
    # nearest_spacing: the median nearest-neighbour distance (the nearest neighbour is a
    # Delaunay neighbour), the upper median, numpy's median for an odd count
    distance, _ = cKDTree(uv).query(uv, k=2)
    nearest = distance[:, 1]
    assert spacing.nearest_spacing(uv, faces) == np.sort(nearest)[len(nearest) // 2]
    assert spacing.nearest_spacing(uv, faces) == np.median(nearest)
    assert spacing.trim_length(uv, faces) == spacing.MAX_EDGE_FACTOR * np.median(nearest)
    # median_edge: numpy's median of the 3F edge lengths, in batches or not
    tri = uv[faces]
    edges = np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2).ravel()
    assert spacing.median_edge(uv, faces) == np.median(edges)
    assert spacing.median_edge(uv, faces) > spacing.nearest_spacing(uv, faces)
    assert spacing.median_edge(uv, np.zeros((0, 3), np.int64)) == 0.0


def test_median_edge_in_batches_is_the_same(monkeypatch):
    uv = np.random.default_rng(9).random((500, 2))
    faces, _ = _core.delaunay(uv)
    whole = spacing.median_edge(uv, faces)
    monkeypatch.setattr(spacing, "EDGE_CHUNK", 7)
    assert spacing.median_edge(uv, faces) == whole
