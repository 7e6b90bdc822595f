"""Faces that would hide a sample from the scanner are never kept where the line of sight is
known (a recorded ``up``)."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

import scanmesh
from conftest import DATA
from scanmesh.stages.hidden import hiding_faces

STEPS = DATA / "scans" / "steps_range_grid.ply"
TILTED = np.array([-0.5, 0.2, 1.0])


def _brute_force(points, faces, sight, depth):
    """Face by face, sample by sample: inside seen along ``sight`` and behind by > depth."""
    s = sight / np.linalg.norm(sight)
    hidden = []
    for t, f in enumerate(faces):
        a, b, c = points[f]
        n = np.cross(b - a, c - a)
        if abs(n @ s) == 0:
            continue
        for k, p in enumerate(points):
            if k in f:
                continue
            # where the ray through p along s meets the face's plane
            lam = ((a - p) @ n) / (s @ n)
            q = p + lam * s
            w = [np.cross(c - b, q - b) @ n, np.cross(a - c, q - c) @ n, np.cross(b - a, q - a) @ n]
            if min(w) > 1e-9 * (n @ n) and lam > depth:
                hidden.append(t)
                break
    return hidden


@pytest.mark.slow
def test_hiding_faces_agree_with_a_brute_force_search():
    rng = np.random.default_rng(5)
    pts = rng.random((80, 3)) * [1, 1, 0.3]
    faces = np.array([rng.choice(80, 3, replace=False) for _ in range(120)])
    sight = np.array([0.1, -0.2, 1.0])
    found = hiding_faces(pts, faces, sight, depth=0.01)
    assert len(found) > 0
    assert found.tolist() == _brute_force(pts, faces, sight, 0.01)


def _steps_with_up():
    """The synthetic range grid as unstructured points whose line of sight (z) is known."""
    sp = scanmesh.read(STEPS)
    return dataclasses.replace(sp, up=np.array([0.0, 0.0, 1.0]), grid=None)


@pytest.mark.parametrize("method", ["delaunay", "lop", "shortest-path"])
def test_no_kept_face_hides_a_sample_when_projected_off_the_line_of_sight(method):
    sp = _steps_with_up()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        s = scanmesh.reconstruct(sp, method, plane=TILTED)
    assert len(hiding_faces(sp.points, s.faces, sp.up)) == 0
    assert "hidden_dropped" in s.options
    # every point is still accounted for
    used = np.zeros(len(sp.points), dtype=bool)
    used[s.faces.ravel()] = True
    key = "unused" if "unused" in s.options else "trimmed"
    used[s.options[key]] = True
    used[s.duplicates[:, 0]] = True
    assert used.all()


def test_delaunay_off_the_line_of_sight_would_hide_samples_without_the_rule():
    sp = _steps_with_up()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        kept = scanmesh.reconstruct(sp, "delaunay", plane=TILTED)
        plain = scanmesh.delaunay(sp.points, plane=TILTED)  # arrays record no line of sight
    assert kept.options["hidden_dropped"] > 0
    assert len(hiding_faces(sp.points, plain.faces, sp.up)) == kept.options["hidden_dropped"]


@pytest.mark.parametrize("scale", [1e-300, 1e300])
def test_hiding_faces_at_extreme_magnitudes(scale):
    rng = np.random.default_rng(5)
    pts = rng.random((80, 3)) * [1, 1, 0.3]
    faces = np.array([rng.choice(80, 3, replace=False) for _ in range(120)])
    sight = np.array([0.1, -0.2, 1.0])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        scaled = hiding_faces(pts * scale, faces, sight, depth=0.01 * scale)
    assert scaled.tolist() == hiding_faces(pts, faces, sight, depth=0.01).tolist()


def test_projected_along_the_line_of_sight_nothing_is_checked():
    sp = _steps_with_up()
    s = scanmesh.reconstruct(sp, "delaunay", plane="z")
    assert "hidden_dropped" not in s.options
