"""The tiling's geometry: the grid of cells over the planar box, each region (cell plus
band), the points a part sends to each region, and the certificate that a tile's
triangle is the single-process one (its circumdisk stays inside the region)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from scanmesh import _core
from scanmesh.distributed._source import Part, load_part


@dataclass(frozen=True)
class Grid:
    """nx x ny cells of the plane, ``size`` wide, cell (0, 0) starting at ``origin``; the
    outer cells reach to infinity. ``band``: how far a region reaches beyond its cell."""

    origin: tuple[float, float]
    size: tuple[float, float]
    shape: tuple[int, int]
    band: float

    @property
    def count(self) -> int:
        """Number of tiles."""
        return self.shape[0] * self.shape[1]

    def cell_index(self, uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(ix, iy) of the cell holding each planar point. O(n)."""
        ix = np.floor((uv[:, 0] - self.origin[0]) / self.size[0])
        iy = np.floor((uv[:, 1] - self.origin[1]) / self.size[1])
        ix = np.clip(np.nan_to_num(ix), 0, self.shape[0] - 1).astype(np.int64)
        iy = np.clip(np.nan_to_num(iy), 0, self.shape[1] - 1).astype(np.int64)
        return ix, iy

    def cells(self, uv: np.ndarray) -> np.ndarray:
        """The tile owning each planar point (ix * ny + iy). O(n)."""
        ix, iy = self.cell_index(uv)
        return ix * self.shape[1] + iy

    def cell_box(self, tile: int) -> tuple[float, float, float, float]:
        """(umin, umax, vmin, vmax) of a cell, infinite at the outer sides."""
        ix, iy = divmod(tile, self.shape[1])
        nx, ny = self.shape
        (ox, oy), (w, h) = self.origin, self.size
        umin = -math.inf if ix == 0 else ox + ix * w
        umax = math.inf if ix == nx - 1 else ox + (ix + 1) * w
        vmin = -math.inf if iy == 0 else oy + iy * h
        vmax = math.inf if iy == ny - 1 else oy + (iy + 1) * h
        return umin, umax, vmin, vmax

    def region(self, tile: int) -> tuple[float, float, float, float]:
        """The cell widened by the band on every side."""
        umin, umax, vmin, vmax = self.cell_box(tile)
        b = self.band
        return umin - b, umax + b, vmin - b, vmax + b

    def tiles_meeting(self, box: tuple[float, float, float, float]) -> list[int]:
        """Tiles whose region meets the box (umin, umax, vmin, vmax)."""
        return [t for t in range(self.count) if _boxes_meet(self.region(t), box)]

    def shifted(self) -> Grid:
        """The grid of the second pass: borders in the middle of this grid's cells, so
        (nx + 1) x (ny + 1) cells, the outer ones half as wide (an axis with one cell keeps
        it: it has no border to anneal)."""
        nx, ny = self.shape
        (ox, oy), (w, h) = self.origin, self.size
        return Grid(
            origin=(ox - w / 2 if nx > 1 else ox, oy - h / 2 if ny > 1 else oy),
            size=self.size,
            shape=(nx + 1 if nx > 1 else 1, ny + 1 if ny > 1 else 1),
            band=self.band,
        )

    def near_borders(self, uv: np.ndarray, width: float) -> np.ndarray:
        """True for points within ``width`` of an inner cell border. O(n)."""
        near = np.zeros(len(uv), dtype=bool)
        for axis in (0, 1):
            for k in range(1, self.shape[axis]):
                border = self.origin[axis] + k * self.size[axis]
                near |= np.abs(uv[:, axis] - border) <= width
        return near


def _boxes_meet(a: tuple[float, ...], b: tuple[float, ...]) -> bool:
    return a[0] <= b[1] and b[0] <= a[1] and a[2] <= b[3] and b[2] <= a[3]


def project_with_box(
    points: np.ndarray, corners: np.ndarray, name: str | None, normal: np.ndarray | None
) -> np.ndarray:
    """Planar coordinates exactly as a single-process projection of the whole scan makes
    them: the core projects onto a frame whose origin is the points' bounding-box centre,
    so the scan's two box corners ride along. O(n)."""
    uv, _ = _core.project(np.concatenate([points, corners]), name, normal)
    return uv[: len(points)]


@dataclass
class Bins:
    """Points of one part that fall in one tile's region."""

    index: np.ndarray  # (k,) int64 global indices
    points: np.ndarray  # (k, 3) float64
    uv: np.ndarray  # (k, 2) float64
    lines: np.ndarray  # (k,) int64


def _bin_part(
    part: Part, corners: np.ndarray, plane: tuple, grid: Grid, tile: int, after: None
) -> Bins:
    """A part's points in the region (cell + band) of ``tile``. ``after``: the gate of
    :func:`scanmesh.distributed._tiles._gated`, only waited for. Each tile reads its parts
    again (a part is read once per tile it meets), so that no part's bins wait in memory
    for a later tile."""
    points, lines = load_part(part)
    uv = project_with_box(points, corners, *plane)
    umin, umax, vmin, vmax = grid.region(tile)
    inside = (uv[:, 0] >= umin) & (uv[:, 0] <= umax) & (uv[:, 1] >= vmin) & (uv[:, 1] <= vmax)
    index = part.offset + np.flatnonzero(inside)
    return Bins(index, points[inside], uv[inside], lines[inside])


def circumcentres(
    uv: np.ndarray, faces: np.ndarray, index: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Circumcentre (m, 2) and radius (m,) of each face, computed from its corners in
    global-index order so that every tile computes the same bits. A collinear face gets
    its centroid and an infinite radius. O(m)."""
    order = np.argsort(index[faces], axis=1)
    f = np.take_along_axis(faces, order, axis=1)
    a, b, c = uv[f[:, 0]], uv[f[:, 1]], uv[f[:, 2]]
    bx, by = (b - a).T
    cx, cy = (c - a).T
    d = 2.0 * (bx * cy - by * cx)
    b2, c2 = bx * bx + by * by, cx * cx + cy * cy
    with np.errstate(divide="ignore", invalid="ignore"):
        ux = (cy * b2 - by * c2) / d
        uy = (bx * c2 - cx * b2) / d
    bad = ~np.isfinite(ux) | ~np.isfinite(uy)
    centre = a + np.column_stack([ux, uy])
    centre[bad] = (a[bad] + b[bad] + c[bad]) / 3
    radius = np.hypot(ux, uy)
    radius[bad] = np.inf
    return centre, radius


def certified(
    centre: np.ndarray, radius: np.ndarray, region: tuple[float, ...], box: tuple[float, ...]
) -> np.ndarray:
    """True where the disk meets no part of the scan's planar box outside the region: the
    parts of the box left, right, below and above the region are rectangles, and a disk
    misses a rectangle when its centre is farther than its radius from it. O(m)."""
    umin, umax, vmin, vmax = region
    bu0, bu1, bv0, bv1 = box
    outside = [
        (bu0, min(umin, bu1), bv0, bv1),
        (max(umax, bu0), bu1, bv0, bv1),
        (bu0, bu1, bv0, min(vmin, bv1)),
        (bu0, bu1, max(vmax, bv0), bv1),
    ]
    ok = np.ones(len(centre), dtype=bool)
    margin = radius * (1 + 1e-9)
    for r0, r1, s0, s1 in outside:
        if not (r0 < r1 and s0 < s1):
            continue
        du = np.maximum(0.0, np.maximum(r0 - centre[:, 0], centre[:, 0] - r1))
        dv = np.maximum(0.0, np.maximum(s0 - centre[:, 1], centre[:, 1] - s1))
        ok &= np.hypot(du, dv) > margin
    return ok
