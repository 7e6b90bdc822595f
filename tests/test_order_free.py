"""Quality figures depend on the face set only: the same faces in another order, with their
corners rotated (or the orientation flipped), give the same numbers, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

import scanmesh
from conftest import bumpy_patch
from scanmesh.evaluate.truth import height_error, normal_error


def shuffled(faces: np.ndarray, rng: np.random.Generator, flip: bool = True) -> np.ndarray:
    """The faces in a random order, each rotated by a random step (and some flipped)."""
    out = faces[rng.permutation(len(faces))].copy()
    step = rng.integers(0, 3, len(out))
    rows = np.arange(len(out))[:, None]
    out = out[rows, (np.arange(3)[None, :] + step[:, None]) % 3]
    if flip:
        f = rng.random(len(out)) < 0.5
        out[f] = out[f][:, [0, 2, 1]]
    return out


def figures(points: np.ndarray, faces: np.ndarray) -> dict:
    q = scanmesh.quality(points, faces)
    return {k: q.as_dict()[k] for k in ("tac_1", "tac_2", "tac_inf", "min_angle_deg")} | {
        "sliver_fraction": q.sliver_fraction,
        "tac": q.tac.tobytes(),
    }


@pytest.mark.parametrize("seed", range(6))
def test_quality_figures_ignore_face_order(seed):
    rng = np.random.default_rng(seed)
    pts = bumpy_patch(300 + 100 * seed, seed)
    pts[:, 2] *= 1 + 10 * rng.random()  # bumpier: many tac terms of different sizes
    faces = np.asarray(scanmesh.delaunay(pts).faces)
    before = figures(pts, faces)
    for _ in range(5):
        after = figures(pts, shuffled(faces, rng))
        assert after == before  # == on floats: bit for bit (no NaN among the scalars)


def test_height_and_normal_error_ignore_face_order():
    rng = np.random.default_rng(7)
    pts = bumpy_patch(400, 7)
    faces = np.asarray(scanmesh.delaunay(pts).faces)
    truth = trimesh.Trimesh(
        np.array([[-5, -5, 0], [5, -5, 0], [5, 5, 0], [-5, 5, 0]], float),
        np.array([[0, 1, 2], [0, 2, 3]]),
        process=False,
    )
    h = height_error((pts, faces), truth, n_samples=5000, seed=3)
    n = normal_error((pts, faces), truth, n_samples=5000, seed=3)
    for _ in range(3):
        other = shuffled(faces, rng)
        assert height_error((pts, other), truth, n_samples=5000, seed=3) == h
        assert normal_error((pts, other), truth, n_samples=5000, seed=3) == n
