"""The command on the files and habits users bring: outputs Surface.save writes, a point file
where a mesh is expected, warnings that say what to do, temporary folders cleaned up."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys

import numpy as np
import pytest
import trimesh

import scanmesh
from conftest import DATA
from test_cli import assert_failed, grid_scan, run, write_xyz


@pytest.mark.slow
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


@pytest.mark.slow
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


@pytest.mark.slow
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


def _lone_point_scan(folder):
    """A scan whose last line is one lone point: in no strip, with an UnusedPointsWarning."""
    points, ids = grid_scan(12, 6)
    return write_xyz(folder / "lone.xyz", np.vstack([points, [[3.0, 3.0, 0.0]]]), np.append(ids, 6))


@pytest.mark.slow
def test_warnings_point_only_to_a_report_that_is_written(tmp_path):
    scan = _lone_point_scan(tmp_path)
    out = tmp_path / "m.stl"
    without = run("reconstruct", scan, "-o", out, "--method", "shortest-path")
    assert without.returncode == 0, without.stderr
    assert "in no strip" in without.stderr
    assert "the --report's" not in without.stderr and "--report lists them" in without.stderr
    report = tmp_path / "r.json"
    given = run("reconstruct", scan, "-o", out, "--method", "shortest-path", "--report", report)
    assert "see the --report's options.unused" in given.stderr
    assert "options.unused" in json.loads(report.read_text())["warnings"][0]


def test_compare_names_the_method_of_each_warning_once(tmp_path):
    scan = _lone_point_scan(tmp_path)
    result = run("compare", scan, "--methods", "shortest-path", "lookahead")
    warned = [line for line in result.stderr.splitlines() if "in no strip" in line]
    assert sorted(warned) == sorted(set(warned))  # no warning twice
    assert any("shortest-path:" in w for w in warned) and any("lookahead:" in w for w in warned)
    assert not any("--report" in w for w in warned)  # compare writes no report


def test_one_face_is_one_face(tmp_path):
    scan = write_xyz(tmp_path / "tri.xyz", np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0.5]]))
    result = run("reconstruct", scan, "-o", tmp_path / "tri.stl", "--method", "delaunay")
    assert result.returncode == 0, result.stderr
    assert re.search(r"\b1 face in\b", result.stdout), result.stdout
    assert "1 faces" not in result.stdout


@pytest.mark.slow
@pytest.mark.parametrize("name", ["conrod_slevin48_onshape.stl", "turbineblade_cut.ply"])
def test_info_on_a_mesh_gives_area_watertightness_and_boundary_as_trimesh(name):
    path = DATA / "cad" / name
    result = run("info", path, "--json")
    assert result.returncode == 0, result.stderr
    data = json.loads(result.stdout)
    peer = trimesh.load_mesh(path)
    assert data["area"] == pytest.approx(peer.area, rel=1e-12)
    assert data["watertight"] == peer.is_watertight
    outline = trimesh.grouping.group_rows(peer.edges_sorted, require_count=1)
    assert data["boundary_edges"] == len(outline)
    assert (data["boundary_loops"] == 0) == data["watertight"]
    text = run("info", path).stdout
    assert "watertight" in text and "boundary" in text and "area" in text
