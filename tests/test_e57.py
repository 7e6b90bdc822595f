"""E57 through pye57: files pye57 (libE57Format) writes read back with their poses, scan
lines (columns), intensity and colours; bad files and a missing pye57 named."""

from __future__ import annotations

import sys

import numpy as np
import pytest

import scanmesh
from scanmesh import MissingExtraError
from scanmesh.errors import FileFormatError


def _structured(rows: int, cols: int, seed: int = 0) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    r, c = np.meshgrid(np.arange(rows), np.arange(cols))
    n = rows * cols
    return {
        "cartesianX": c.ravel().astype(float),
        "cartesianY": r.ravel().astype(float),
        "cartesianZ": np.sin(c.ravel() / 3.0),
        "intensity": rng.random(n),
        "colorRed": rng.integers(0, 256, n).astype(np.uint8),
        "colorGreen": rng.integers(0, 256, n).astype(np.uint8),
        "colorBlue": rng.integers(0, 256, n).astype(np.uint8),
        "rowIndex": r.ravel().astype(np.int32),
        "columnIndex": c.ravel().astype(np.int32),
    }


@pytest.fixture
def e57_file(tmp_path):
    pye57 = pytest.importorskip("pye57")
    scans = [_structured(20, 15, 0), _structured(10, 12, 1)]
    path = tmp_path / "two.e57"
    out = pye57.E57(str(path), mode="w")
    out.write_scan_raw(scans[0])
    out.write_scan_raw(scans[1], translation=np.array([100.0, 0.0, 0.0]))
    out.close()
    return path, scans


def test_scans_read_back_with_poses_lines_and_colours(e57_file):
    path, scans = e57_file
    scan = scanmesh.read(path)
    assert len(scan) == 300 + 120 and scan.extra["scan_starts"] == [0, 300]
    first = np.column_stack([scans[0][f"cartesian{c}"] for c in "XYZ"])
    second = np.column_stack([scans[1][f"cartesian{c}"] for c in "XYZ"]) + [100.0, 0.0, 0.0]
    assert np.allclose(scan.points, np.concatenate([first, second]))
    # columns are the lines, numbered on from the first scan's 15 columns
    assert np.array_equal(scan.line_ids[:300], scans[0]["columnIndex"])
    assert np.array_equal(scan.line_ids[300:], scans[1]["columnIndex"] + 15)
    assert scan.n_lines == 15 + 12
    red = np.concatenate([s["colorRed"] for s in scans])
    assert np.array_equal(scan.point_data["red"], red)
    assert np.allclose(
        scan.point_data["intensity"], np.concatenate([s["intensity"] for s in scans])
    )
    surface = scanmesh.reconstruct(path, "shortest-path")
    assert np.array_equal(surface.colors[:, 0], red) and len(surface.faces) > 0


def test_a_bad_e57_is_named(tmp_path, e57_file):
    path, _ = e57_file
    (tmp_path / "fake.e57").write_bytes(b"ply\nformat ascii 1.0\n")
    with pytest.raises(FileFormatError, match="not an E57 file"):
        scanmesh.read(tmp_path / "fake.e57")
    data = path.read_bytes()
    (tmp_path / "cut.e57").write_bytes(data[: len(data) // 2])
    with pytest.raises(FileFormatError, match="not a readable E57 file"):
        scanmesh.read(tmp_path / "cut.e57")


def test_without_pye57_the_extra_is_named(tmp_path, monkeypatch):
    path = tmp_path / "x.e57"
    path.write_bytes(b"ASTM-E57" + b"\0" * 100)
    monkeypatch.setitem(sys.modules, "pye57", None)
    with pytest.raises(MissingExtraError, match=r'pip install "scanmesh\[e57\]"'):
        scanmesh.read(path)
