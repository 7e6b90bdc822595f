"""Point location in a planar triangulation, and the height of the mesh there: which
triangle holds each query point, and the height of that triangle's plane at it. The
holdout judge, the truth measures and the plane choice all measure points against meshes
this way."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np

#: Candidate (point, triangle) pairs evaluated per step (bounds temporary memory).
PAIRS_PER_STEP: int = 1 << 20

#: Most (cell, triangle) entries of the bins per triangle and query point, on average.
#: Cells are sized by a typical triangle; where sizes are very uneven (clusters far apart,
#: joined by a few long triangles) each long triangle would cover millions of them, so the
#: cells are widened until the bins fit (fuzz seed 75336: 55.7M entries, 425 MiB, for 60
#: points).
ENTRIES_PER_ITEM: int = 8


def expand(
    count: np.ndarray, step: int = PAIRS_PER_STEP
) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """Walk ``sum(count)`` (owner, item) pairs in steps of at most ``step``.

    Yields (owner, offset): (n,) int64 arrays, owners ascending; item ``offset`` of ``owner``.
    """
    count = np.asarray(count, dtype=np.int64)
    ends = np.cumsum(count)
    if len(ends) == 0:
        return
    starts = ends - count
    total = int(ends[-1])
    for first in range(0, total, step):
        flat = np.arange(first, min(first + step, total), dtype=np.int64)
        owner = np.searchsorted(ends, flat, side="right")
        yield owner, flat - starts[owner]


def locate(uv: np.ndarray, tri_uv: np.ndarray, tol: float = 1e-9) -> np.ndarray:
    """The planar triangle holding each query point, or -1.

    Parameters
    ----------
    uv : (N, 2) float
        Query points.
    tri_uv : (F, 3, 2) float
        Triangle corners (either orientation), e.g. a planar triangulation.
    tol : float
        A point this far outside a triangle, relative to the triangle's size, still counts
        as inside (points on shared edges do not fall through).

    Returns
    -------
    (N,) int64
        Index of a triangle holding the point (the lowest one where several do), -1 where
        none does. Triangles are binned in a uniform grid of cells about twice a typical
        triangle's size, widened until the bins hold at most :data:`ENTRIES_PER_ITEM` x
        (N + F) entries: O(N + F) memory always, O(N + F) time for triangulations of even
        size.
    """
    uv = np.ascontiguousarray(uv, dtype=np.float64)
    if len(tri_uv) == 0 or len(uv) == 0:
        return np.full(len(uv), -1, dtype=np.int64)
    lo, hi = tri_uv.min(axis=1), tri_uv.max(axis=1)
    origin = lo.min(axis=0)
    extent = float((hi.max(axis=0) - origin).max()) or 1.0
    cell = max(2.0 * float(np.median((hi - lo).max(axis=1))), extent / 4096)
    budget = ENTRIES_PER_ITEM * (len(tri_uv) + len(uv))
    while True:  # ends: at cell >= extent every triangle spans at most 2 x 2 cells
        cell_lo = np.floor((lo - origin) / cell).astype(np.int64)
        span = np.floor((hi - origin) / cell).astype(np.int64) - cell_lo + 1
        if int(span.prod(axis=1).sum()) <= budget:
            break
        cell *= 2.0
    width = int(np.floor((hi.max(axis=0)[0] - origin[0]) / cell)) + 2
    keys, tris = [], []
    for owner, off in expand(span.prod(axis=1)):
        cx = cell_lo[owner, 0] + off % span[owner, 0]
        cy = cell_lo[owner, 1] + off // span[owner, 0]
        keys.append(cy * width + cx)
        tris.append(owner)
    key = np.concatenate(keys)
    order = np.argsort(key, kind="stable")
    key, tri = key[order], np.concatenate(tris)[order]
    q = np.floor((uv - origin) / cell).astype(np.int64)
    on_grid = (q[:, 0] >= 0) & (q[:, 0] < width) & (q[:, 1] >= 0)
    qkey = np.where(on_grid, q[:, 1] * width + q[:, 0], -1)
    start = np.searchsorted(key, qkey, side="left")
    stop = np.searchsorted(key, qkey, side="right")
    # orientation-free barycentric test: the point is on the same side of all three edges
    a, b, c = tri_uv[:, 0], tri_uv[:, 1], tri_uv[:, 2]
    area2 = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    sign = np.sign(area2)
    best = np.full(len(uv), len(tri_uv), dtype=np.int64)  # lowest holding triangle so far
    for rows, item in expand(stop - start):
        t = tri[start[rows] + item]
        p = uv[rows]
        slack = -tol * np.abs(area2[t])
        inside = np.ones(len(t), dtype=bool)
        for i, j in ((0, 1), (1, 2), (2, 0)):
            e0, e1 = tri_uv[t, i], tri_uv[t, j]
            cross = (e1[:, 0] - e0[:, 0]) * (p[:, 1] - e0[:, 1]) - (e1[:, 1] - e0[:, 1]) * (
                p[:, 0] - e0[:, 0]
            )
            inside &= sign[t] * cross >= slack
        inside &= area2[t] != 0
        np.minimum.at(best, rows[inside], t[inside])
    return np.where(best < len(tri_uv), best, -1)


def heights_at(
    uv: np.ndarray, tri_uv: np.ndarray, tri_h: np.ndarray, face: np.ndarray
) -> np.ndarray:
    """Height of the plane of triangle ``face[i]`` at ``uv[i]`` (linear interpolation):
    (N,) float from ``uv`` (N, 2), corners ``tri_uv`` (F, 3, 2) and heights ``tri_h``
    (F, 3). O(N)."""
    a, b, c = tri_uv[face, 0], tri_uv[face, 1], tri_uv[face, 2]
    d1, d2, dp = b - a, c - a, uv - a
    det = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    w1 = (dp[:, 0] * d2[:, 1] - dp[:, 1] * d2[:, 0]) / det
    w2 = (d1[:, 0] * dp[:, 1] - d1[:, 1] * dp[:, 0]) / det
    h = tri_h[face]
    return h[:, 0] + w1 * (h[:, 1] - h[:, 0]) + w2 * (h[:, 2] - h[:, 0])


def normal_distances(
    query: np.ndarray, tri: np.ndarray, axes: np.ndarray, normal: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Distance along ``normal`` from each query point to the mesh over the plane spanned by
    ``axes``: the height difference to the triangle holding the point's projection.

    ``query`` (Q, 3), ``tri`` (F, 3, 3) the mesh's corners, ``axes`` (3, 2) and ``normal``
    (3,) an orthonormal frame. Returns (Q,) float64 distances (nan where no triangle holds
    the projection: beyond the outline or in a hole) and (Q,) int64 the holding triangle
    (-1: none). O((F + Q) log F)."""
    tri_uv = tri @ axes
    uv = query @ axes
    face = locate(uv, tri_uv)
    inside = face >= 0
    got = np.full(len(query), np.nan)
    got[inside] = np.abs(
        query[inside] @ normal - heights_at(uv[inside], tri_uv, tri @ normal, face[inside])
    )
    return got, face
