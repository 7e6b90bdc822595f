"""A closed mesh (a CAD export) given where scan points are expected is scanned by the virtual
digitizer, not meshed vertex by vertex; a mesh that does not close is read as its vertices."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import trimesh

import scanmesh
from conftest import DATA
from scanmesh.scan.closed_part import CLOSED_PART_POINTS

ROD = DATA / "cad" / "conrod_slevin48_onshape.stl"  # thickness along y: its profile seen along y
POCKET = DATA / "cad" / "octagonal_pocket.ply"  # a plate pocketed from +z
BLADE_PATCH = DATA / "cad" / "turbineblade_cut.ply"  # part of a blade's surface: open


@pytest.mark.parametrize(("path", "axis"), [(ROD, 1), (POCKET, 2)])
def test_a_closed_part_is_scanned_along_its_largest_silhouette(path, axis):
    with pytest.warns(scanmesh.ClosedPartWarning, match="is a closed mesh") as caught:
        surface = scanmesh.reconstruct(path, "delaunay")
    assert "--up=" + "xyz"[axis] in str(caught[0].message)
    part = trimesh.load_mesh(path)
    points = surface.vertices
    assert abs(len(points) - CLOSED_PART_POINTS) < 0.1 * CLOSED_PART_POINTS
    # a height field over the scanning plane, seen from +axis: few steep triangles, and
    # every point the highest of the part above it (a ray cast by trimesh, independent of
    # the digitizer) for a sample
    assert surface.steep_fraction < 0.1
    assert np.allclose(np.abs(surface.scan.frame.normal), np.eye(3)[axis])
    sample = points[np.random.default_rng(0).choice(len(points), 200, replace=False)]
    up = np.eye(3)[axis]
    origins = sample + up * 10 * part.scale
    hits, rays, _ = part.ray.intersects_location(origins, np.tile(-up, (len(sample), 1)))
    top = np.full(len(sample), -np.inf)
    np.maximum.at(top, rays, hits @ up)
    np.testing.assert_allclose(top, sample @ up, atol=1e-9 * part.scale)


def test_the_plane_asked_for_is_the_scanning_direction():
    with pytest.warns(scanmesh.ClosedPartWarning, match="along z"):
        surface = scanmesh.reconstruct(ROD, "delaunay", plane="z")
    assert np.allclose(surface.scan.frame.normal, [0, 0, 1])


def test_what_read_returned_is_scanned_the_same_way():
    with pytest.warns(scanmesh.ClosedPartWarning):
        from_path = scanmesh.reconstruct(POCKET, "delaunay")
    with pytest.warns(scanmesh.ClosedPartWarning):
        from_read = scanmesh.reconstruct(scanmesh.read(POCKET), "delaunay")
    np.testing.assert_array_equal(from_path.vertices, from_read.vertices)
    np.testing.assert_array_equal(from_path.faces, from_read.faces)


def test_an_open_mesh_is_read_as_its_vertices():
    assert not trimesh.load_mesh(BLADE_PATCH).is_watertight
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a patch cut from a blade: steep, with curtains
        warnings.simplefilter("error", scanmesh.ClosedPartWarning)
        surface = scanmesh.reconstruct(BLADE_PATCH, "delaunay")
    np.testing.assert_array_equal(surface.vertices, scanmesh.read(BLADE_PATCH).points)


def test_given_line_ids_keep_the_vertices():
    points = scanmesh.read(ROD)
    lines = np.arange(len(points.points)) // 20
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the vertices as given: steep, folded
        warnings.simplefilter("error", scanmesh.ClosedPartWarning)
        surface = scanmesh.reconstruct(ROD, "shortest-path", lines=lines)
    np.testing.assert_array_equal(surface.vertices, points.points)
