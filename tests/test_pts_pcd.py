"""PTS and PCD readers: files Open3D wrote (tests/data/peers) read back to the points that
made them, an Open3D cross-check when it is installed, and bad files refused by name."""

import gzip

import numpy as np
import pytest

import scanmesh
from conftest import DATA
from scanmesh.errors import FileFormatError
from scanmesh.formats.pcd import read_pcd
from scanmesh.formats.pts import read_pts

PEERS = DATA / "peers"


def _peer_cloud():
    """The points and colours tests/data/peers was written from (ATTRIBUTION.md)."""
    rng = np.random.default_rng(7)
    xyz = rng.random((40, 3))
    return xyz, rng.integers(0, 256, (40, 3)).astype(np.uint8)


@pytest.mark.parametrize(
    ("name", "tolerance"),
    [
        ("open3d_cloud_ascii.pcd", 1e-10),  # 10 decimals
        ("open3d_cloud_binary.pcd", 1e-7),  # float32
        ("open3d_cloud.pts", 1e-10),
    ],
)
def test_files_open3d_wrote_read_back_to_their_points_and_colours(name, tolerance):
    xyz, rgb = _peer_cloud()
    scan = scanmesh.read(PEERS / name)
    assert scan.points.shape == (40, 3)
    assert np.abs(scan.points - xyz).max() < tolerance
    assert np.array_equal(scan.point_data["red"], rgb[:, 0])
    assert np.array_equal(np.stack([scan.point_data[c] for c in ("red", "green", "blue")], 1), rgb)
    surface = scanmesh.reconstruct(scan, "delaunay")
    assert np.array_equal(surface.colors, rgb)


def test_open3d_reads_what_scanmesh_reads(tmp_path):
    o3d = pytest.importorskip("open3d")
    rng = np.random.default_rng(3)
    xyz, rgb = rng.random((500, 3)), rng.random((500, 3))
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(xyz))
    cloud.colors = o3d.utility.Vector3dVector(rgb)
    for name, text in [("a.pcd", True), ("b.pcd", False), ("c.pts", True)]:
        o3d.io.write_point_cloud(str(tmp_path / name), cloud, write_ascii=text)
        theirs = o3d.io.read_point_cloud(str(tmp_path / name))
        ours = scanmesh.read(tmp_path / name)
        assert np.array_equal(ours.points, np.asarray(theirs.points)), name
        assert np.array_equal(_rgb(ours) / 255.0, np.asarray(theirs.colors)), name


def _rgb(scan):
    return np.stack([scan.point_data[c] for c in ("red", "green", "blue")], 1).astype(float)


def test_pts_with_several_scans_intensity_and_no_count(tmp_path):
    rows = ["2", "0 0 0 -5 10 20 30", "1 0 0 7 40 50 60", "1", "0 1 1 3 1 2 3"]
    (tmp_path / "s.pts").write_text("\n".join(rows) + "\n")
    scan = read_pts(tmp_path / "s.pts")
    assert scan.points.tolist() == [[0, 0, 0], [1, 0, 0], [0, 1, 1]]
    assert scan.point_data["intensity"].tolist() == [-5, 7, 3]
    assert scan.point_data["intensity"].dtype == np.float32
    assert scan.point_data["green"].tolist() == [20, 50, 2]
    assert scan.extra["scan_starts"] == [0, 2]
    (tmp_path / "plain.pts").write_text("0 0 0\n1 0 0\n0 1 0\n")
    assert len(read_pts(tmp_path / "plain.pts")) == 3
    (tmp_path / "plain.pts.gz").write_bytes(gzip.compress(b"3\n0 0 0\n1 0 0\n0 1 0\n"))
    assert len(scanmesh.read(tmp_path / "plain.pts.gz")) == 3


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("3\n0 0 0\n1 0 0\n", "declares 3 lines, the file ends after 2"),
        ("2\n0 0 0 1 2\n1 0 0 1 2\n", "found 5"),
        ("2\n0 0 0 1 2 300\n1 0 0 1 2 3\n", "blue=300.0; PTS colours are integers 0..255"),
        ("x\n0 0 0\n", "line 1: expected a point count"),
        ("2\n0 0 0\n1 0 0 5\n", "line 3: expected 3 values"),
        ("1\n0 nan 0\n", "non-finite y"),
        ("0\n", "holds no points"),
    ],
)
def test_bad_pts_files_are_named(tmp_path, text, match):
    (tmp_path / "bad.pts").write_text(text)
    with pytest.raises(FileFormatError, match=match):
        scanmesh.read(tmp_path / "bad.pts")


def _pcd_head(fields, size, kind, width, height, data, count=None):
    count = count or " ".join("1" for _ in fields.split())
    return (
        f"# .PCD v0.7\nVERSION 0.7\nFIELDS {fields}\nSIZE {size}\nTYPE {kind}\nCOUNT {count}\n"
        f"WIDTH {width}\nHEIGHT {height}\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {width * height}\n"
        f"DATA {data}\n"
    ).encode()


def test_organized_binary_pcd_rows_are_scan_lines_and_nan_points_dropped(tmp_path):
    h, w = 4, 5
    rec = np.dtype(
        [("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("intensity", "<f4"), ("fpfh", "<f4", (3,))]
    )
    rows = np.zeros(h * w, dtype=rec)
    jj, ii = np.meshgrid(np.arange(w), np.arange(h))
    rows["x"], rows["y"] = jj.ravel(), ii.ravel()
    rows["z"] = 0.1 * rows["x"] ** 2
    rows["intensity"] = np.arange(h * w)
    rows["x"][[3, 17]] = np.nan  # no return
    head = _pcd_head("x y z intensity fpfh", "4 4 4 4 4", "F F F F F", w, h, "binary", "1 1 1 1 3")
    (tmp_path / "o.pcd").write_bytes(head + rows.tobytes())
    scan = read_pcd(tmp_path / "o.pcd")
    assert len(scan) == h * w - 2 and scan.extra["dropped_invalid"] == 2
    assert scan.extra["ignored_fields"] == ["fpfh"]
    assert np.array_equal(scan.line_ids, np.delete(np.repeat(np.arange(h), w), [3, 17]))
    assert scan.grid.shape == (h, w) and scan.grid[0, 3] == -1 and scan.grid[3, 2] == -1
    kept = np.delete(np.arange(h * w), [3, 17])
    assert np.array_equal(scan.points[scan.grid[1, 0]], [0, 1, 0])
    assert np.array_equal(scan.point_data["intensity"], kept.astype(np.float32))
    surface = scanmesh.reconstruct(scan, "shortest-path")
    assert len(surface.faces) > 0


@pytest.mark.parametrize(
    ("body", "match"),
    [
        (_pcd_head("x y z", "4 4 4", "F F F", 3, 1, "binary") + b"\0" * 20, "only 20 remain"),
        (_pcd_head("x y z", "4 4 4", "F F F", 3, 1, "binary_compressed"), "binary_compressed"),
        (_pcd_head("x y", "4 4", "F F", 3, 1, "ascii"), "lack z"),
        (_pcd_head("x y z", "4 4 4", "F F F", 3, 1, "ascii") + b"0 0 0\n1 0 0\n", "truncated"),
        (_pcd_head("x y z", "4 4 4", "F F F", 2, 1, "ascii") + b"0 0 0\n1 0 q\n", "'q' is not"),
        (_pcd_head("x y z", "4 4", "F F F", 2, 1, "ascii"), "3 FIELDS, 2 SIZE"),
        (_pcd_head("x y z", "4 4 4", "F F F", 1, 1, "ascii") + b"nan 0 0\n", "no point with"),
        (b"# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\n", "no DATA line"),
    ],
)
def test_bad_pcd_files_are_named(tmp_path, body, match):
    (tmp_path / "bad.pcd").write_bytes(body)
    with pytest.raises(FileFormatError, match=match):
        scanmesh.read(tmp_path / "bad.pcd")


def test_pcd_found_by_content_and_ascii_rgb_unpacked(tmp_path):
    packed = np.array([(10 << 16) | (20 << 8) | 30, (200 << 16) | (100 << 8) | 50], np.uint32)
    as_float = packed.view(np.float32)
    body = (
        _pcd_head("x y z rgb", "4 4 4 4", "F F F F", 3, 1, "ascii")
        + (
            f"0 0 0 {float(as_float[0])!r}\n1 0 0 {float(as_float[1])!r}\n"
            f"0 1 0 {float(as_float[0])!r}\n"
        ).encode()
    )
    (tmp_path / "cloud.dat").write_bytes(body)
    scan = scanmesh.read(tmp_path / "cloud.dat")
    assert scan.extra["format"] == "pcd"
    assert scan.point_data["red"].tolist() == [10, 200, 10]
    assert scan.point_data["blue"].tolist() == [30, 50, 30]
