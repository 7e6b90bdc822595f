"""Holes narrower than the planar trim length (a bore through a flat plate, at one height, so
no depth jump shows) are left open by trimming, and scans without holes keep their area."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
import trimesh

import scanmesh
from scanmesh import _core
from scanmesh.evaluate.truth import TrueSurface
from scanmesh.stages.options import HOLE_FACTOR, MAX_EDGE_FACTOR

#: The plate: radius 10, 2 thick, a bore of radius 1.1 through its middle, scanned along z
#: at spacing 0.5: the bore is 4.4 spacings across, narrower than the planar trim length.
R, BORE, SPACING = 10.0, 1.1, 0.5


@pytest.fixture(scope="module")
def plate() -> trimesh.Trimesh:
    return trimesh.creation.annulus(r_min=BORE, r_max=R, height=2.0, sections=256)


def planar_area(uv: np.ndarray, faces: np.ndarray) -> float:
    a, b, c = (uv[faces[:, k]] for k in range(3))
    cross = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    return float(0.5 * np.abs(cross).sum())


def farthest_from(truth: TrueSurface, points: np.ndarray, faces: np.ndarray) -> float:
    """Largest distance to the part over 20,000 points sampled on the mesh."""
    mesh = trimesh.Trimesh(points, faces, process=False)
    samples, _ = trimesh.sample.sample_surface(mesh, 20_000, seed=0)
    return float(truth.distance(samples).max())


def test_the_factor_is_the_cores():
    assert HOLE_FACTOR == _core.DEFAULT_HOLE_FACTOR
    assert 1 < HOLE_FACTOR < MAX_EDGE_FACTOR


def test_a_bore_under_the_trim_length_is_left_open_and_the_plate_kept(plate):
    points, _ = scanmesh.simulate_scan(plate, up="z", along="x", spacing=SPACING)
    assert np.ptp(points[:, 2]) == 0  # one height: no depth jump to see
    truth = TrueSurface(plate)
    d = scanmesh.delaunay(points, plane="z")
    uv = d.scan.uv
    assert d.options["max_edge"] > 2 * BORE  # planar trimming alone cannot open the bore
    hull, _ = _core.delaunay(uv)
    planar_only = _core.trim_long_edges(uv, hull, d.options["max_edge"])
    # Planar trimming leaves a sheet over the bore (a point about the bore's radius from
    # the part); the default trimming leaves nothing farther than half a spacing (the
    # chords between neighbouring samples on the rim).
    assert farthest_from(truth, points, planar_only) > 0.8 * BORE
    assert farthest_from(truth, points, d.faces) < SPACING
    _core.validate(uv, d.faces)
    # The plate is kept: what was dropped is at most the bore, and the mesh covers the
    # top face (its area from trimesh, an independent measure) up to the rim chords.
    top = float(plate.area_faces[plate.face_normals[:, 2] > 0.5].sum())
    assert math.isclose(top, math.pi * (R**2 - BORE**2), rel_tol=1e-3)
    kept = planar_area(uv, d.faces)
    assert 0 < planar_area(uv, planar_only) - kept <= math.pi * BORE**2
    assert 0.95 * top < kept < top
    # The methods that start from the trimmed Delaunay inherit the open bore.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        lop = scanmesh.reconstruct(points, "lop", plane="z")
    assert farthest_from(truth, points, lop.faces) < SPACING


def test_noise_along_the_rays_changes_nothing_the_rule_keeps(plate):
    clean, _ = scanmesh.simulate_scan(plate, up="z", along="x", spacing=SPACING)
    noisy, _ = scanmesh.simulate_scan(
        plate, up="z", along="x", spacing=SPACING, noise=0.1 * SPACING, seed=3
    )
    a = scanmesh.delaunay(clean, plane="z")
    b = scanmesh.delaunay(noisy, plane="z")
    assert planar_area(b.scan.uv, b.faces) == pytest.approx(planar_area(a.scan.uv, a.faces))


@pytest.mark.parametrize("jitter", [0.15, 0.3])
def test_jittered_samples_without_holes_keep_their_area(jitter):
    # A flat 60 x 60 grid (spacing 1) jittered in the plane: no hole, nothing to drop but
    # the outline's planar-trimmed fringe.
    rng = np.random.default_rng(7)
    x, y = np.meshgrid(np.arange(60.0), np.arange(60.0))
    xy = np.column_stack([x.ravel(), y.ravel()]) + jitter * rng.standard_normal((3600, 2))
    points = np.column_stack([xy, 0.1 * np.sin(0.3 * xy[:, 0])])
    d = scanmesh.delaunay(points, plane="z")
    uv = d.scan.uv
    hull, _ = _core.delaunay(uv)
    planar_only = _core.trim_long_edges(uv, hull, d.options["max_edge"])
    assert planar_area(uv, d.faces) >= 0.999 * planar_area(uv, planar_only)
