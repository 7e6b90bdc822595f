"""merge's ``simplify``: fewer faces where the surface is flat, within a tolerance of the
mesh one face pair per voxel crossing gives, still closed, with its genus and labels."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

import scanmesh
from scanmesh import shape
from scanmesh.errors import ParameterError
from scanmesh.evaluate.digitizer import axis_views
from scanmesh.scan.slivers import sliver_share


def turned_box_views():
    """A 2 x 1 x 0.6 box turned 30 degrees about z (four edges across the grid's cells),
    scanned from the six axis directions, and its rotation."""
    turn = Rotation.from_euler("z", 30, degrees=True).as_matrix()
    box = trimesh.creation.box((2.0, 1.0, 0.6))
    motion = np.eye(4)
    motion[:3, :3] = turn
    box.apply_transform(motion)
    return box, turn, axis_views(box, 0.04, noise=0.04 / 30, grazing=80.0, seed=1)


@pytest.fixture(scope="module")
def box_full_and_simplified():
    box, turn, views = turned_box_views()
    full = scanmesh.merge(views, simplify=0.0)
    return box, turn, full, scanmesh.merge(views, simplify=0.1)


def test_a_simplified_box_is_closed_near_the_full_mesh_with_far_fewer_faces(
    box_full_and_simplified,
):
    box, _, full, simple = box_full_and_simplified
    voxel = simple.options["voxel"]
    mesh = trimesh.Trimesh(simple.vertices, simple.faces, process=False)
    assert mesh.is_watertight and mesh.is_winding_consistent
    assert shape.euler_characteristic(simple.faces) == 2
    assert len(mesh.split(only_watertight=False)) == 1
    assert mesh.volume > 0
    # a plane-dominated part: most of the faces go
    assert len(simple.faces) < 0.3 * len(full.faces), (len(simple.faces), len(full.faces))
    assert simple.options["simplified"] == {
        "faces_before": len(full.faces),
        "faces_after": len(simple.faces),
    }
    # every vertex of the full mesh within the tolerance of the simplified one (trimesh's
    # distances, not the core's)
    _, dist, _ = trimesh.proximity.closest_point(mesh, full.vertices)
    assert dist.max() <= 0.1 * voxel * (1 + 1e-6), dist.max() / voxel
    # and as near the box as the full mesh was
    full_mesh = trimesh.Trimesh(full.vertices, full.faces, process=False)
    points = trimesh.sample.sample_surface(mesh, 20_000, seed=0)[0]
    full_points = trimesh.sample.sample_surface(full_mesh, 20_000, seed=0)[0]
    rms = [
        np.sqrt(np.mean(trimesh.proximity.closest_point(box, p)[1] ** 2))
        for p in (points, full_points)
    ]
    assert rms[0] < 1.2 * rms[1] + 0.01 * voxel, rms


def test_a_simplified_box_keeps_its_creases_and_no_slivers(box_full_and_simplified):
    """Faces within a voxel of the box's edges keep the normal of the box face under them
    as the full mesh does (mean error within a degree of it), and the collapses add no
    triangle under the sliver angle (those of the full mesh, along its creases, stay)."""
    box, turn, full, simple = box_full_and_simplified
    voxel = simple.options["voxel"]

    def crease_error(surface):
        mesh = trimesh.Trimesh(surface.vertices, surface.faces, process=False)
        points, face = trimesh.sample.sample_surface(mesh, 50_000, seed=0)
        near, dist, tri = trimesh.proximity.closest_point(box, points)
        to_edge = np.sort(np.abs([1.0, 0.5, 0.3] - np.abs(near @ turn)), axis=1)[:, 1]
        crease = (dist < voxel) & (to_edge < voxel)
        cos = np.abs(np.einsum("ij,ij->i", mesh.face_normals[face], box.face_normals[tri]))
        return np.degrees(np.arccos(np.clip(cos, 0, 1)))[crease].mean()

    assert crease_error(simple) < crease_error(full) + 1.0
    slivers = [sliver_share(m.vertices, m.faces) * len(m.faces) for m in (simple, full)]
    assert slivers[0] <= slivers[1], slivers


def test_simplified_labels_keep_their_areas():
    """A box seen from above only: measured top, inferred sides, filled bottom; each
    label's area within 2 % of the full mesh's (their borders do not move)."""
    box = trimesh.creation.box((2.0, 1.0, 0.6))
    top = scanmesh.simulate_range_scan(box, up="z", spacing=0.04, noise=0.04 / 30, seed=0)
    full = scanmesh.merge([top], simplify=0.0)
    simple = scanmesh.merge([top], simplify=0.1)
    assert shape.is_watertight(simple.faces)
    assert shape.euler_characteristic(simple.faces) == 2
    assert len(simple.faces) < 0.5 * len(full.faces)
    for label, area in full.label_areas.items():
        assert simple.label_areas[label] == pytest.approx(area, rel=0.02), label


@pytest.mark.parametrize("value", [-0.1, float("nan"), "a lot"])
def test_a_bad_tolerance_is_refused_by_name(value):
    box, _, views = turned_box_views()
    with pytest.raises(ParameterError, match="simplify"):
        scanmesh.merge(views[:1], simplify=value)
