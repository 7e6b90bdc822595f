"""Per-point values a file carries (PLY colours and scalars) kept on the Surface and written
to PLY, and gzip-compressed inputs, cross-checked against trimesh's PLY reader and writer."""

import gzip
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh

import scanmesh
from scanmesh.errors import FileFormatError, ParameterError
from scanmesh.formats._source import gunzip
from scanmesh.formats.write import save_mesh


def _cloud(n=200, seed=0):
    rng = np.random.default_rng(seed)
    pts = rng.random((n, 3))
    pts[:, 2] = np.sin(3 * pts[:, 0])
    return pts, rng.integers(0, 256, (n, 4), dtype=np.uint8)


def test_ply_colours_written_by_trimesh_reach_the_mesh_and_its_ply(tmp_path):
    pts, rgba = _cloud()
    trimesh.PointCloud(pts, colors=rgba).export(tmp_path / "c.ply")
    scan = scanmesh.read(tmp_path / "c.ply")
    assert sorted(scan.point_data) == ["alpha", "blue", "green", "red"]
    surface = scanmesh.reconstruct(scan, "delaunay")
    assert np.array_equal(surface.colors, rgba)
    # the same from the path
    assert np.array_equal(scanmesh.reconstruct(tmp_path / "c.ply", "lop").colors, rgba)
    surface.save(tmp_path / "out.ply")
    back = trimesh.load(tmp_path / "out.ply", process=False)
    assert np.array_equal(back.faces, surface.faces)
    assert np.array_equal(back.visual.vertex_colors, rgba)
    again = scanmesh.read(tmp_path / "out.ply")
    colours = {
        k: v.dtype for k, v in again.point_data.items() if k in ("red", "green", "blue", "alpha")
    }
    assert colours == dict.fromkeys(("red", "green", "blue", "alpha"), np.dtype("u1"))


def test_ascii_ply_scalars_keep_their_values_and_types(tmp_path):
    pts, _ = _cloud(50)
    quality = np.linspace(-1.5, 2.5, 50)
    label = np.arange(50) % 7
    rows = "\n".join(
        f"{x!r} {y!r} {z!r} {q!r} {k}"
        for (x, y, z), q, k in zip(pts.tolist(), quality.tolist(), label.tolist(), strict=True)
    )
    head = (
        "ply\nformat ascii 1.0\nelement vertex 50\nproperty double x\nproperty double y\n"
        "property double z\nproperty float quality\nproperty int label\nend_header\n"
    )
    (tmp_path / "s.ply").write_text(head + rows + "\n")
    surface = scanmesh.reconstruct(tmp_path / "s.ply", "delaunay")
    assert surface.point_data["quality"].dtype == np.float32
    assert np.array_equal(surface.point_data["quality"], quality.astype(np.float32))
    assert np.array_equal(surface.point_data["label"], label)
    assert surface.colors is None
    surface.save(tmp_path / "out.ply")
    head_out = (tmp_path / "out.ply").read_bytes().split(b"end_header")[0].decode()
    assert "property float quality" in head_out and "property int label" in head_out
    back = scanmesh.read(tmp_path / "out.ply")
    assert np.array_equal(back.point_data["quality"], surface.point_data["quality"])
    assert np.array_equal(back.point_data["label"], label)
    assert np.array_equal(back.points, surface.vertices)
    # STL cannot hold them: the Surface still saves, save_mesh asked for them refuses
    surface.save(tmp_path / "out.stl")
    with pytest.raises(ParameterError, match="use .ply"):
        save_mesh(tmp_path / "x.stl", surface.vertices, surface.faces, point_data={"q": quality})


def test_point_data_from_the_caller_is_checked_and_written(tmp_path):
    pts, _ = _cloud(60)
    surface = scanmesh.reconstruct(pts, "delaunay")
    assert surface.point_data == {}
    height = pts[:, 2].copy()
    surface.point_data["elevation"] = height
    surface.point_data["big"] = np.arange(60, dtype=np.int64) * 10**12  # no int64 in PLY
    surface.save(tmp_path / "h.ply")
    back = scanmesh.read(tmp_path / "h.ply")
    assert np.array_equal(back.point_data["elevation"], height)
    assert np.array_equal(back.point_data["big"], np.arange(60) * 10**12)  # as double
    with pytest.raises(ParameterError, match="one number per point"):
        scanmesh.Surface(pts, surface.faces, point_data={"h": height[:5]})
    with pytest.raises(ParameterError, match="coordinates or normals"):
        save_mesh(tmp_path / "y.ply", pts, surface.faces, point_data={"z": height})


@pytest.mark.parametrize("name", ["scan.xyz.gz", "scan.ply.gz", "scan.gz"])
def test_gzip_compressed_inputs_read_as_the_plain_file(tmp_path, name):
    pts, rgba = _cloud(80)
    if ".xyz" in name:
        plain = tmp_path / "scan.xyz"
        scanmesh.formats.write.write_points(plain, pts)
    else:
        plain = tmp_path / "scan.ply"
        trimesh.PointCloud(pts, colors=rgba).export(plain)
    (tmp_path / name).write_bytes(gzip.compress(plain.read_bytes()))
    a, b = scanmesh.read(plain), scanmesh.read(tmp_path / name)
    assert np.array_equal(a.points, b.points)
    assert a.point_data.keys() == b.point_data.keys()
    surface = scanmesh.reconstruct(tmp_path / name, "delaunay")
    assert np.array_equal(surface.faces, scanmesh.reconstruct(plain, "delaunay").faces)


def test_bad_gzip_inputs_are_named(tmp_path):
    pts, _ = _cloud(500)
    scanmesh.formats.write.write_points(tmp_path / "s.xyz", pts)
    packed = gzip.compress((tmp_path / "s.xyz").read_bytes())
    (tmp_path / "cut.xyz.gz").write_bytes(packed[: len(packed) // 2])
    with pytest.raises(FileFormatError, match="truncated gzip"):
        scanmesh.read(tmp_path / "cut.xyz.gz")
    (tmp_path / "bad.xyz.gz").write_bytes(packed[:10] + b"\xff" * 50)
    with pytest.raises(FileFormatError, match="corrupt gzip"):
        scanmesh.read(tmp_path / "bad.xyz.gz")
    with pytest.raises(FileFormatError, match="decompresses to more than 1,000"):
        gunzip(tmp_path / "s.xyz.gz", packed, limit=1000)
    np.save(tmp_path / "p.npy", pts)
    (tmp_path / "p.npy.gz").write_bytes(gzip.compress((tmp_path / "p.npy").read_bytes()))
    with pytest.raises(FileFormatError, match="decompress it first"):
        scanmesh.read(tmp_path / "p.npy.gz")
    # two members, as concatenated gzip files are: read as one
    half = len(pts) // 2
    scanmesh.formats.write.write_points(tmp_path / "a.xyz", pts[:half])
    body = (tmp_path / "a.xyz").read_bytes()
    rows = body.split(b"\n", 1)[1]  # the second member without the header row
    (tmp_path / "two.xyz.gz").write_bytes(gzip.compress(body) + gzip.compress(rows))
    assert len(scanmesh.read(tmp_path / "two.xyz.gz")) == 2 * half


def test_the_command_writes_the_scans_colours_to_its_ply(tmp_path):
    peers = Path(__file__).resolve().parent / "data" / "peers"
    out = tmp_path / "mesh.ply"
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "scanmesh",
            "reconstruct",
            str(peers / "open3d_cloud.pts"),
            "-o",
            str(out),
            "--method",
            "delaunay",
            "-q",
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr
    scan = scanmesh.read(peers / "open3d_cloud.pts")
    mesh = trimesh.load(out, process=False)
    assert np.array_equal(
        mesh.visual.vertex_colors[:, :3],
        scanmesh.Surface(scan.points, np.asarray(mesh.faces), point_data=scan.point_data).colors,
    )
    assert np.array_equal(scanmesh.read(out).point_data["intensity"], scan.point_data["intensity"])
