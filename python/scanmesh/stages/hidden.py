"""Faces that would hide a sample: the scanner's ray to a sample passes through them.

The space between a range scanner and every sample it recorded is empty, so a triangle whose
interior a ray of sight crosses in front of a sample cannot be surface. With the rays
parallel (a line scanner, a simulated scan, a file's recorded ``up``), a sample ``p`` is
hidden by face ``T`` when ``p`` seen along the line of sight falls strictly inside ``T`` and
lies behind ``T``'s plane (farther from the scanner) by more than a tolerance.

A planar triangulation projected along the line of sight itself has no sample inside a
face, so the rule only acts when the scan was projected on another plane (``plane=`` given,
or chosen by the data over the recorded ``up``).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from scanmesh.measures import unit_factors
from scanmesh.scan.planar import PlanarScan
from scanmesh.surface import Surface

#: A sample counts as behind a face when it lies farther than this multiple of the median
#: edge length behind the face's plane (measurement noise along the ray stays in front).
HIDDEN_DEPTH_FACTOR = 0.5

#: Barycentric margin: samples on a face's edges or corners (its own vertices) are not
#: inside it.
_INSIDE_EPS = 1e-9

#: (face, sample) candidate pairs examined per chunk (bounds memory: about 100 B per pair).
_CHUNK_PAIRS = 1 << 21


def _frame(sight: np.ndarray) -> np.ndarray:
    """(3, 3) rows: two unit axes across ``sight`` and ``sight`` itself."""
    s = sight / np.linalg.norm(sight)
    helper = np.eye(3)[int(np.argmin(np.abs(s)))]
    u = np.cross(s, helper)
    u /= np.linalg.norm(u)
    return np.array([u, np.cross(s, u), s])


def hiding_faces(
    points: np.ndarray, faces: np.ndarray, sight: np.ndarray, depth: float | None = None
) -> np.ndarray:
    """Faces whose interior a ray of sight crosses in front of a sample.

    Parameters
    ----------
    points : (N, 3) float64
    faces : (M, 3) int64
    sight : (3,) float
        Direction towards the scanner (rays travel along ``-sight``).
    depth : float, optional
        How far behind a face's plane a sample must lie to count as hidden (model units);
        default HIDDEN_DEPTH_FACTOR x the median edge length.

    Returns
    -------
    (K,) int64
        Indices of the hiding faces, ascending. O(M + pairs) with the samples bucketed in
        cells of the median projected edge: about the faces' projected area over the cell's.
    """
    if len(faces) == 0:
        return np.empty(0, dtype=np.int64)
    frame = _frame(np.asarray(sight, dtype=np.float64))
    # in a box of side about 1 (a power of two: exact), so that coordinates from 1e-300 to
    # 1e300 neither overflow nor underflow
    down, _ = unit_factors(float(np.abs(points).max()))
    points = points * down[0] * down[1]
    if depth is not None:
        depth = depth * down[0] * down[1]
    local = points @ frame.T  # (N, 3): across, across, height towards the scanner
    xy, h = local[:, :2], local[:, 2]
    tri = xy[faces]  # (M, 3, 2)
    edges = np.linalg.norm(points[faces] - points[np.roll(faces, 1, axis=1)], axis=2)
    if depth is None:
        depth = HIDDEN_DEPTH_FACTOR * float(np.median(edges))
    planar = np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2)
    cell = float(np.median(planar))
    if not cell > 0:
        cell = float(planar.max()) or 1.0
    lo = xy.min(axis=0)
    key = np.floor((xy - lo) / cell).astype(np.int64)
    ncol, nrow = int(key[:, 0].max()) + 1, int(key[:, 1].max()) + 1
    flat = key[:, 1] * ncol + key[:, 0]
    order = np.argsort(flat, kind="stable")
    starts = np.searchsorted(flat[order], np.arange(nrow * ncol + 1))
    # each face's cell range
    fmin = np.floor((tri.min(axis=1) - lo) / cell).astype(np.int64)
    fmax = np.floor((tri.max(axis=1) - lo) / cell).astype(np.int64)
    fmin = np.maximum(fmin, 0)
    fmax[:, 0] = np.minimum(fmax[:, 0], ncol - 1)
    fmax[:, 1] = np.minimum(fmax[:, 1], nrow - 1)
    span = np.maximum(fmax - fmin + 1, 0)
    n_cells = span[:, 0] * span[:, 1]
    # (face, cell) pairs, then (face, sample) pairs through the buckets
    face_of = np.repeat(np.arange(len(faces)), n_cells)
    k = np.arange(len(face_of)) - np.repeat(np.cumsum(n_cells) - n_cells, n_cells)
    cx = fmin[face_of, 0] + k % span[face_of, 0]
    cy = fmin[face_of, 1] + k // span[face_of, 0]
    c = cy * ncol + cx
    count = starts[c + 1] - starts[c]
    hidden = np.zeros(len(faces), dtype=bool)
    bounds = np.concatenate([[0], np.cumsum(count)])
    first = 0
    while first < len(c):
        last = int(np.searchsorted(bounds, bounds[first] + _CHUNK_PAIRS, side="right")) - 1
        last = max(last, first + 1)
        cc, ff, nn = c[first:last], face_of[first:last], count[first:last]
        owner = np.repeat(ff, nn)
        offset = np.arange(int(nn.sum())) - np.repeat(np.cumsum(nn) - nn, nn)
        sample = order[np.repeat(starts[cc], nn) + offset]
        _mark_hidden(tri, h, faces, local, xy, owner, sample, depth, hidden)
        first = last
    return np.flatnonzero(hidden).astype(np.int64)


def _mark_hidden(tri, h, faces, local, xy, owner, sample, depth, hidden) -> None:
    """Set ``hidden[owner]`` where ``sample`` lies strictly inside face ``owner`` seen along
    the sight and more than ``depth`` behind its plane."""
    a = tri[owner, 0]
    ab, ac, ap = tri[owner, 1] - a, tri[owner, 2] - a, xy[sample] - a
    det = ab[:, 0] * ac[:, 1] - ab[:, 1] * ac[:, 0]
    ok = np.abs(det) > 0
    det = np.where(ok, det, 1.0)
    w1 = (ap[:, 0] * ac[:, 1] - ap[:, 1] * ac[:, 0]) / det
    w2 = (ab[:, 0] * ap[:, 1] - ab[:, 1] * ap[:, 0]) / det
    w0 = 1.0 - w1 - w2
    inside = ok & (w0 > _INSIDE_EPS) & (w1 > _INSIDE_EPS) & (w2 > _INSIDE_EPS)
    corners = h[faces[owner]]
    height = w0 * corners[:, 0] + w1 * corners[:, 1] + w2 * corners[:, 2]
    behind = inside & (h[sample] < height - depth)
    hidden[owner[behind]] = True


def drop_hidden(scan: PlanarScan, surface: Surface) -> Surface:
    """``surface`` less its faces that would hide a sample from the scanner (see
    :func:`hiding_faces`), when ``scan`` records the line of sight (``PlanarScan.up``) and
    was projected on another plane; otherwise ``surface`` itself. The count goes to
    ``options["hidden_dropped"]`` and the points left in no face join ``options["trimmed"]``
    (``"unused"`` for the strip methods)."""
    if scan.up is None or len(surface.faces) == 0:
        return surface
    if abs(float(np.dot(scan.up, scan.frame.normal))) >= 1.0 - 1e-12:
        return surface  # projected along the sight: no sample lies inside a face
    hiding = hiding_faces(scan.points, surface.faces, scan.up)
    if len(hiding) == 0:
        return dataclasses.replace(surface, options={**surface.options, "hidden_dropped": 0})
    keep = np.ones(len(surface.faces), dtype=bool)
    keep[hiding] = False
    faces = surface.faces[keep]
    before = np.unique(surface.faces)
    lost = np.setdiff1d(before, np.unique(faces))
    key = "unused" if "unused" in surface.options else "trimmed"
    known = np.asarray(surface.options.get(key, np.empty(0, dtype=np.int64)), dtype=np.int64)
    options = {
        **surface.options,
        "hidden_dropped": len(hiding),
        key: np.union1d(known, lost).astype(np.int64),
    }
    return dataclasses.replace(surface, faces=faces, options=options)


__all__ = ["HIDDEN_DEPTH_FACTOR", "drop_hidden", "hiding_faces"]
