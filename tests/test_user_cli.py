"""The command on the files and habits users bring: outputs Surface.save writes, a point file
where a mesh is expected, warnings that say what to do, temporary folders cleaned up."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest
import trimesh

import scanmesh
from test_cli import assert_failed, grid_scan, run, write_xyz


@pytest.mark.parametrize("ending", [".glb", ".html"])
def test_reconstruct_writes_what_surface_save_writes(tmp_path, ending):
    points, ids = grid_scan()
    scan = write_xyz(tmp_path / "scan.xyz", points, ids)
    out = tmp_path / f"out{ending}"
    result = run("reconstruct", scan, "-o", out, "--method", "delaunay", "--quiet")
    assert result.returncode == 0, result.stderr
    data = out.read_bytes()
    if ending == ".glb":
        mesh = trimesh.load(out, force="mesh")
        assert len(mesh.faces) > 0
        assert data[:4] == b"glTF"
    else:
        assert b"<html" in data[:500].lower()


def test_reconstruct_still_refuses_an_unknown_ending(tmp_path):
    points, ids = grid_scan()
    scan = write_xyz(tmp_path / "scan.xyz", points, ids)
    err = assert_failed(run("reconstruct", scan, "-o", tmp_path / "out.xyz"))
    assert ".glb" in err and ".stl" in err


@pytest.mark.parametrize("command", ["render", "view", "info-truth"])
@pytest.mark.parametrize("ending", [".xyz", ".ply"])
def test_a_point_file_where_a_mesh_is_expected_says_so(tmp_path, command, ending):
    points, ids = grid_scan()
    scan = tmp_path / f"scan{ending}"
    if ending == ".xyz":
        with open(scan, "w") as f:
            f.write("# x y z\n")  # a header comment, as scan files have
        with open(scan, "a") as f:
            np.savetxt(f, points)
    else:
        trimesh.PointCloud(points).export(scan)
    if command == "render":
        args = ["render", scan, "-o", tmp_path / "p.png"]
    elif command == "view":
        args = ["view", scan, "-o", tmp_path / "v.html"]
    else:
        args = ["compare", write_xyz(tmp_path / "s.xyz", points, ids), "--truth", scan]
    err = assert_failed(run(*args))
    assert "mesh" in err and "expected" in err and str(scan) in err
    assert "convert string" not in err


def test_view_leaves_no_folder_per_run(tmp_path):
    points, ids = grid_scan()
    mesh = tmp_path / "mesh.stl"
    scanmesh.reconstruct(points, "delaunay", plane="z").save(mesh)
    temp = tmp_path / "temp"
    temp.mkdir()
    env = {**os.environ, "TMPDIR": str(temp)}
    pages = []
    for _ in range(3):
        result = subprocess.run(
            [sys.executable, "-m", "scanmesh", "view", str(mesh), "--no-open"],
            capture_output=True,
            text=True,
            env=env,
            timeout=120,
        )
        assert result.returncode == 0, result.stderr
        pages.append(result.stdout + result.stderr)
    assert len(list(temp.iterdir())) == 1  # one folder for every view, not one per run
    assert all("mesh.html" in page for page in pages)
    assert len(list(next(temp.iterdir()).glob("*.html"))) == 1
