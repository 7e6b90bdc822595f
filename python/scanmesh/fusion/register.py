"""Rigid refinement of view poses: point-to-plane ICP between overlapping views.

Each pass moves every view but the first (which fixes the world) onto all the others: its
samples are paired with the nearest sample of the other views within ``max_distance``
whose normal agrees (cosine above :data:`NORMAL_AGREEMENT`), and the small rotation and
translation minimising the squared distances to the partners' tangent planes (linearised,
Chen & Medioni 1991) is applied. The residual is the RMS point-to-plane distance over the
pairs of every view, before and after. O(passes · views · N log N).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from scanmesh.fusion.views import View

#: Pairs whose normals' cosine is below this are not the same surface seen twice.
NORMAL_AGREEMENT = 0.7

#: Pairs whose distance to the partner's plane exceeds this many robust sigmas (1.4826 x the
#: median) are left out.
TRIM = 3.0

#: Samples of a view used per pass at most (a fixed-seed subset of larger views).
MAX_PAIRS = 20_000


def _moved(pose: np.ndarray, points: np.ndarray, normals: np.ndarray):
    return points @ pose[:3, :3].T + pose[:3, 3], normals @ pose[:3, :3].T


def _pairs(
    k: int, poses: list[np.ndarray], samples: list[tuple[np.ndarray, np.ndarray]], reach: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """View k's samples (world), their partners on the other views and the partners'
    normals, for the pairs within ``reach`` whose normals agree."""
    others = [_moved(poses[j], *samples[j]) for j in range(len(samples)) if j != k]
    target = np.concatenate([o[0] for o in others])
    target_n = np.concatenate([o[1] for o in others])
    src, src_n = _moved(poses[k], *samples[k])
    dist, idx = cKDTree(target).query(src, distance_upper_bound=reach)
    ok = np.isfinite(dist)
    ok[ok] &= np.einsum("ij,ij->i", src_n[ok], target_n[idx[ok]]) > NORMAL_AGREEMENT
    p, q, n = src[ok], target[idx[ok]], target_n[idx[ok]]
    # pairs far off the others' planes are different surfaces (an edge, a silhouette)
    r = np.abs(np.einsum("ij,ij->i", p - q, n))
    keep = r <= TRIM * 1.4826 * np.median(r) if len(r) else r > 0
    return p[keep], q[keep], n[keep]


def view_residuals(
    views: list[View],
    normals: list[np.ndarray],
    kept: list[np.ndarray],
    reach: float,
    most: int = MAX_PAIRS,
    seed: int = 0,
) -> np.ndarray:
    """(V,) each view's RMS point-to-plane distance (world units) to the others' samples
    within ``reach`` whose normals agree, the pairs far off trimmed as in
    :func:`refine_poses` (NaN: a view paired with none): its alignment residual, the
    scanner's noise included. At most ``most`` samples of a view (a fixed-seed subset).
    O(views · N log N)."""
    samples = _samples(views, normals, kept, most, np.random.default_rng(seed))
    poses = [v.pose for v in views]
    out = np.full(len(views), np.nan)
    for k in range(len(views)):
        p, q, n = _pairs(k, poses, samples, reach)
        if len(p):
            out[k] = float(np.sqrt(np.mean(np.einsum("ij,ij->i", p - q, n) ** 2)))
    return out


def _samples(views, normals, kept, most: int, rng) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per view, at most ``most`` of its kept points (scanner coordinates) and normals."""
    samples = []
    for view, n, keep in zip(views, normals, kept, strict=True):
        at = np.arange(len(keep))
        if len(keep) > most:
            at = rng.choice(len(keep), most, replace=False)
        samples.append((view.points[keep[at]], n[at]))
    return samples


def _residual(poses, samples, reach: float) -> float:
    sq, count = 0.0, 0
    for k in range(len(samples)):
        p, q, n = _pairs(k, poses, samples, reach)
        sq += float(np.sum(np.einsum("ij,ij->i", p - q, n) ** 2))
        count += len(p)
    return float(np.sqrt(sq / count)) if count else float("nan")


def refine_poses(
    views: list[View],
    normals: list[np.ndarray],
    kept: list[np.ndarray],
    reach: float,
    passes: int = 10,
    seed: int = 0,
) -> tuple[list[View], float, float]:
    """The views with refined poses, and the residual (world units) before and after.

    ``normals[k]`` (K, 3) are unit normals in view k's scanner coordinates of its points
    ``kept[k]``; ``reach`` is the largest distance between paired samples."""
    samples = _samples(views, normals, kept, MAX_PAIRS, np.random.default_rng(seed))
    poses = [v.pose.copy() for v in views]
    before = _residual(poses, samples, reach)
    for _ in range(passes):
        for k in range(1, len(views)):
            p, q, n = _pairs(k, poses, samples, reach)
            if len(p) < 6:
                continue
            a = np.hstack([np.cross(p, n), n])  # d(residual) / d(rotation, translation)
            b = -np.einsum("ij,ij->i", p - q, n)
            x, *_ = np.linalg.lstsq(a, b, rcond=None)
            step = np.eye(4)
            step[:3, :3] = Rotation.from_rotvec(x[:3]).as_matrix()
            step[:3, 3] = x[3:]
            poses[k] = step @ poses[k]
    after = _residual(poses, samples, reach)
    return [replace(v, pose=m) for v, m in zip(views, poses, strict=True)], before, after
