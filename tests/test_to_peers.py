"""Surface.to_pyvista() / to_open3d() / to_trimesh(): the same triangles over the same
vertex indices with the scan's colours and values, cross-checked with each library's own
area; a clear MissingExtraError without the library; fake modules where it is missing."""

from __future__ import annotations

import sys
import types

import numpy as np
import pytest
import trimesh

import scanmesh
from conftest import DATA
from scanmesh import MissingExtraError

COLOURED = DATA / "peers" / "open3d_cloud.pts"  # 40 points with intensity and colours


@pytest.fixture(scope="module")
def surface():
    return scanmesh.reconstruct(COLOURED, "delaunay")


def test_to_trimesh_keeps_indices_and_colours(surface):
    mesh = surface.to_trimesh()
    assert np.array_equal(mesh.faces, surface.faces)
    assert np.array_equal(mesh.visual.vertex_colors[:, :3], surface.colors)
    assert mesh.area == pytest.approx(surface.area, rel=1e-12)


def test_to_pyvista_when_installed(surface):
    pyvista = pytest.importorskip("pyvista")
    mesh = surface.to_pyvista()
    assert isinstance(mesh, pyvista.PolyData)
    assert np.array_equal(mesh.points, surface.vertices)
    assert np.array_equal(mesh.faces.reshape(-1, 4)[:, 1:], surface.faces)
    assert np.array_equal(mesh.point_data["RGB"], surface.colors)
    assert np.array_equal(mesh.point_data["intensity"], surface.point_data["intensity"])
    assert mesh.area == pytest.approx(surface.area, rel=1e-9)


def test_to_open3d_when_installed(surface):
    o3d = pytest.importorskip("open3d")
    mesh = surface.to_open3d()
    assert isinstance(mesh, o3d.geometry.TriangleMesh)
    assert np.array_equal(np.asarray(mesh.vertices), surface.vertices)
    assert np.array_equal(np.asarray(mesh.triangles), surface.faces)
    assert np.allclose(np.asarray(mesh.vertex_colors) * 255, surface.colors)
    assert np.allclose(np.asarray(mesh.vertex_normals), surface.normals)
    assert mesh.get_surface_area() == pytest.approx(surface.area, rel=1e-9)


@pytest.mark.parametrize(("method", "module"), [("to_pyvista", "pyvista"), ("to_open3d", "open3d")])
def test_a_missing_library_is_named_with_its_extra(surface, monkeypatch, method, module):
    monkeypatch.setitem(sys.modules, module, None)  # import fails as if not installed
    with pytest.raises(MissingExtraError, match=rf'pip install "scanmesh\[{module}\]"'):
        getattr(surface, method)()


def test_to_pyvista_builds_the_cells_pyvista_reads(surface, monkeypatch):
    """A stand-in module records what PolyData is given: points and the cell array in
    VTK's layout (3, i, j, k per triangle), as PyVista documents it."""
    made = {}

    class PolyData:
        def __init__(self, points, faces):
            made["points"], made["faces"] = points, faces
            self.point_data = {}

    monkeypatch.setitem(sys.modules, "pyvista", types.SimpleNamespace(PolyData=PolyData))
    mesh = surface.to_pyvista()
    cells = made["faces"].reshape(-1, 4)
    assert (cells[:, 0] == 3).all() and np.array_equal(cells[:, 1:], surface.faces)
    assert np.array_equal(made["points"], surface.vertices)
    assert set(mesh.point_data) == {"intensity", "red", "green", "blue", "RGB"}


def test_to_open3d_passes_int32_triangles_and_unit_colours(surface, monkeypatch):
    class Vector:
        def __init__(self, values):
            self.values = np.asarray(values)

    class TriangleMesh:
        def __init__(self, vertices, triangles):
            self.vertices, self.triangles = vertices, triangles

    fake = types.SimpleNamespace(
        utility=types.SimpleNamespace(Vector3dVector=Vector, Vector3iVector=Vector),
        geometry=types.SimpleNamespace(TriangleMesh=TriangleMesh),
    )
    monkeypatch.setitem(sys.modules, "open3d", fake)
    mesh = surface.to_open3d()
    assert mesh.triangles.values.dtype == np.int32
    assert np.array_equal(mesh.triangles.values, surface.faces)
    assert mesh.vertex_colors.values.max() <= 1.0
    assert np.array_equal(np.rint(mesh.vertex_colors.values * 255), surface.colors)


def test_without_colours_nothing_is_invented():
    rng = np.random.default_rng(0)
    plain = scanmesh.reconstruct(rng.random((50, 3)), "delaunay")
    assert plain.colors is None
    assert isinstance(plain.to_trimesh(), trimesh.Trimesh)
    o3d = pytest.importorskip("open3d")
    assert not plain.to_open3d().has_vertex_colors() and isinstance(o3d.__name__, str)


def test_open3d_reads_the_saved_ply_when_installed(surface, tmp_path):
    o3d = pytest.importorskip("open3d")
    surface.save(tmp_path / "m.ply")
    mesh = o3d.io.read_triangle_mesh(str(tmp_path / "m.ply"))
    assert np.array_equal(np.asarray(mesh.triangles), surface.faces)
    assert np.allclose(np.asarray(mesh.vertex_normals), surface.normals)
    assert np.allclose(np.asarray(mesh.vertex_colors) * 255, surface.colors)


def test_pyvista_reads_the_saved_ply_when_installed(surface, tmp_path):
    pyvista = pytest.importorskip("pyvista")
    surface.save(tmp_path / "m.ply")
    mesh = pyvista.read(tmp_path / "m.ply")
    assert np.allclose(mesh.points, surface.vertices)
    assert np.array_equal(mesh.faces.reshape(-1, 4)[:, 1:], surface.faces)
    assert np.allclose(mesh.point_data["Normals"], surface.normals, atol=1e-6)
