"""Mesh files (STL, OBJ, OFF, PLY with faces) read as scan points: their distinct vertices,
cross-checked against trimesh's merged vertices, meshed again by one command."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

import scanmesh
from conftest import DATA
from scanmesh.errors import FileFormatError
from test_cli import run


def _rows(a: np.ndarray) -> set[tuple[float, ...]]:
    return set(map(tuple, np.asarray(a, dtype=np.float64).tolist()))


@pytest.mark.parametrize("ending", [".stl", ".obj", ".off", ".ply"])
def test_a_mesh_file_gives_its_distinct_vertices(tmp_path, ending):
    part = trimesh.load(DATA / "cad" / "conrod_slevin48_onshape.stl")  # merged by trimesh
    path = tmp_path / f"rod{ending}"
    part.export(path)
    scan = scanmesh.read(path)
    want = trimesh.load(path, process=True).vertices  # trimesh merges repeated vertices
    assert len(scan) == len(want) == 524  # the data README's count
    assert _rows(scan.points) == _rows(want)
    assert scan.line_ids is None
    if ending != ".ply":  # PLY is read by its own reader, vertex properties kept
        assert scan.extra["faces_ignored"] == 1044


def test_stl_vertices_keep_the_order_they_first_appear_in():
    scan = scanmesh.read(DATA / "cad" / "conrod_slevin48_onshape.stl")
    corners = trimesh.load(DATA / "cad" / "conrod_slevin48_onshape.stl", process=False)
    flat = np.asarray(corners.vertices, dtype=np.float64)  # 3 per face, in file order
    seen, order = set(), []
    for row in map(tuple, flat.tolist()):
        if row not in seen:
            seen.add(row)
            order.append(row)
    np.testing.assert_array_equal(scan.points, np.array(order))
    assert scan.extra["repeats_dropped"] == len(flat) - len(order)


@pytest.mark.slow
def test_the_command_meshes_a_mesh_file_again(tmp_path):
    """A mesh that does not close (a reconstruction saved with its faces) is its vertices;
    a closed one is scanned instead (test_closed_part.py)."""
    first, out = tmp_path / "first.ply", tmp_path / "again.ply"
    source = DATA / "scans" / "fran_cut.vtk"
    assert run("reconstruct", source, "-o", first, "--method", "delaunay", "-q").returncode == 0
    result = run("reconstruct", first, "-o", out, "--method", "delaunay", "-q")
    assert result.returncode == 0, result.stderr
    back = trimesh.load(out, process=False)
    np.testing.assert_array_equal(back.vertices, scanmesh.read(first).points)
    assert len(back.faces) > 0 and "closed mesh" not in result.stderr


def test_bad_mesh_files_are_named(tmp_path):
    (tmp_path / "empty.stl").write_bytes(b"")
    with pytest.raises(FileFormatError, match="empty.stl.*empty"):
        scanmesh.read(tmp_path / "empty.stl")
    (tmp_path / "junk.obj").write_text("this is not\na mesh\n")
    with pytest.raises(FileFormatError, match="junk.obj"):
        scanmesh.read(tmp_path / "junk.obj")


def test_ply_faces_with_scalar_properties_are_walked_and_checked(tmp_path):
    """Faces that carry a scalar beside their corner list (a colour, trimesh's ``stl``)
    are read past as one record per face; lists of varying length there are refused."""
    head = (
        "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\n"
        "property float y\nproperty float z\nelement face {n}\n"
        "property list uchar int vertex_indices\nproperty uchar red\nend_header\n"
    )
    vertices = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0.5]], "<f4").tobytes()
    face = np.dtype([("n", "u1"), ("v", "<i4", (3,)), ("red", "u1")])
    faces = np.array([(3, (0, 1, 2), 9), (3, (0, 2, 3), 7)], face).tobytes()
    (tmp_path / "t.ply").write_bytes(head.format(n=2).encode() + vertices + faces)
    np.testing.assert_array_equal(
        scanmesh.read(tmp_path / "t.ply").points, np.frombuffer(vertices, "<f4").reshape(4, 3)
    )
    (tmp_path / "cut.ply").write_bytes(head.format(n=2).encode() + vertices + faces[:-3])
    with pytest.raises(FileFormatError, match="truncated PLY"):
        scanmesh.read(tmp_path / "cut.ply")
    quad = np.array([4, 0, 0, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0, 3, 0, 0, 0, 5], "u1").tobytes()
    (tmp_path / "mixed.ply").write_bytes(head.format(n=2).encode() + vertices + faces[:14] + quad)
    with pytest.raises(FileFormatError, match="varying length"):
        scanmesh.read(tmp_path / "mixed.ply")
