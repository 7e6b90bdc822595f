"""Delaunay, LOP and annealing on a Dask cluster: the plane cut into tiles with an overlap band.

The scan stays in its parts (files of consecutive scan lines, :class:`Part`); no process
ever holds all of it. What the client holds is small: bounds, a seeded sample of at most
``SAMPLE_POINTS`` points (for the plane), per-tile counts, and the few values of the exact
median spacing search.

Rules, in order:

- **Plane.** ``plane=`` as given (an axis name or a normal; "best-fit" and None are
  resolved on the sample, see below). None: :func:`scanmesh.plane_choice.choose_plane` on a
  seeded sample of at most ``SAMPLE_POINTS`` points drawn from all parts; a least-squares
  answer becomes the sample's least-squares normal. The frame's origin is the bounding-box
  centre of the whole scan (an exact min/max reduction), and every part is projected by the
  core with that box's two corners appended, so the planar coordinates are bit for bit the
  single-process ones.
- **Tiles.** A grid of nx x ny cells over the planar bounding box, about ``TILE_POINTS``
  points each; the outer cells reach to infinity. Each point belongs to the one cell that
  holds it (its *own* tile) and goes to every tile whose *region* (cell widened by the
  band on each side) holds it: each tile reads the parts its region meets and keeps their
  points inside it. The band is ``BAND_EDGES`` trimming lengths (``max_edge``; for the
  default, estimated as 5 x the median spacing of the first ``SPACING_SAMPLE`` points of
  each part, median over parts).
- **Delaunay ownership.** Each tile triangulates its region with the single-process core
  (Delaunay, then trimming at the global ``max_edge``: the exact global median spacing is
  found by a distributed selection over the tiles' nearest-neighbour distances). A triangle
  belongs to the tile whose cell holds its circumcentre (computed from its corners in
  global-index order). All triangles of a cocircular polygon share that centre, so a tie is
  decided by one tile. A triangle is *certified* when its circumdisk meets no part of the
  scan's bounding box outside the region: then every point that could lie in the disk is
  in the tile, and the triangle is the single-process one. ``sums["uncertified"]`` counts
  owned triangles that are not (0 on every scan tested; a larger ``band_edges`` removes
  them).
- **LOP and annealing.** Pass 1: each tile optimizes the triangles whose three corners it
  owns; every other triangle is frozen (a flip changes only its four corners, so tiles
  never touch the same triangle and the union stays one valid triangulation), and writes
  its mesh to a file in the scratch folder. Pass 2: tiles shifted by half a cell each read
  their share of those files, and each optimizes again the triangles within
  ``SEAM_EDGES`` trimming lengths of pass 1's cell borders. The final owner of a triangle
  is the shifted tile holding its lowest-index corner. A piece's border vertices
  are boundary vertices to the core, so their tac does not steer the flips next to them
  (the core's one-process tiles keep their full angle sums): the second pass re-anneals
  exactly those rims of pass 1.

Memory: every run through the tiles (the median search's distances, the noise estimate,
pass 1, pass 2, Delaunay's blocks) keeps at most ``TILES_PER_THREAD`` tiles per worker
thread in flight (:func:`_gated`), so a worker's peak follows the tile's size, not the
scan's. What stays across a run is small: pass 1's file names and counts, and for the
median search each tile's own distances (8 bytes per point, spread over the workers).

Seeds: tile t of pass k anneals on a seed derived from (seed, k, t); automatic ``chains``
(0) means one chain per piece. Annealing's automatic tie tolerance comes from the medians
over tiles of the noise estimate and of the median edge. Measured (tests, a 14,400-point
ridge in 2 tiles, 100 sweeps): tac_1 and height RMS within 2 % of one process; on 1M
points in 4 tiles, tac_1 3 % above (benches/results/distributed_tiles.md).
"""

from __future__ import annotations

import dataclasses
import math
import os
import shutil
import tempfile
import uuid
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from scanmesh import _core
from scanmesh.anneal import ANNEAL_DEFAULTS, SEED_OPTION, drive
from scanmesh.delaunay import JUMP_FACTOR, MAX_EDGE_FACTOR, MAX_EDGE_OPTION
from scanmesh.distributed._output import FaceBlock
from scanmesh.distributed._source import Part, load_part
from scanmesh.errors import ParameterError, ScanmeshError
from scanmesh.methods import TABLE
from scanmesh.noise import median_edge, noise, tie_tolerance
from scanmesh.projection import Frame, PlaneSpec, plane_args
from scanmesh.scan import PlanarScan

#: Points per tile the grid aims at (a tile's Delaunay and annealing state fit in ~1 GB).
TILE_POINTS: int = 1_000_000

#: Most points of the seeded sample the plane is chosen on.
SAMPLE_POINTS: int = 20_000

#: Points at the start of each part whose median spacing estimates the scan's.
SPACING_SAMPLE: int = 50_000

#: The band around each cell, in trimming lengths: wide enough that the circumdisks of the
#: trimmed triangles a tile owns, and the 1-rings trimming measures, lie in the region.
BAND_EDGES: float = 4.0

#: The second pass of LOP and annealing works within this many trimming lengths of the
#: first pass's cell borders.
SEAM_EDGES: float = 3.0

#: Values per tile and round of the exact median search.
MEDIAN_SAMPLE: int = 1024

#: Tiles in flight per worker thread: tile t's first task waits for tile t - k's last
#: (k this times the cluster's threads), so a worker holds the data of a few tiles whatever
#: the scan's size; pass 1's meshes go to disk, read back by pass 2's tiles.
TILES_PER_THREAD: int = 2

#: Methods run in tiles.
METHODS = ("delaunay", "lop", "anneal")


# ---------------------------------------------------------------------------------------
# Geometry of the tiling


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


def make_grid(box: tuple[float, float, float, float], points: int, band: float) -> Grid:
    """A grid over the planar box with about TILE_POINTS points per cell (uniform density
    assumed), cells as square as the box allows. Inner borders are offset from round
    fractions of the box by an irrational share of a cell, so that exactly cocircular grid
    points rarely have their common centre on a border."""
    umin, umax, vmin, vmax = box
    width, height = max(umax - umin, 1e-300), max(vmax - vmin, 1e-300)
    tiles = max(1, math.ceil(points / TILE_POINTS))
    nx = max(1, round(math.sqrt(tiles * width / height)))
    ny = max(1, math.ceil(tiles / nx))
    w, h = width / nx, height / ny
    shift = 0.1 * (math.sqrt(5.0) - 1.0)  # irrational: no grid of round numbers meets it
    return Grid((umin + shift * w, vmin + shift * h), (w, h), (nx, ny), band)


# ---------------------------------------------------------------------------------------
# Work on the parts (run on workers)


def _part_survey(part: Part, sample: int, seed: int) -> dict[str, Any]:
    """A part's 3-D bounds, count and seeded sample."""
    points, _ = load_part(part)
    rng = np.random.default_rng([seed, part.index])
    take = rng.choice(len(points), size=min(sample, len(points)), replace=False)
    return {
        "lo": points.min(axis=0),
        "hi": points.max(axis=0),
        "count": len(points),
        "sample": points[np.sort(take)],
    }


def project_with_box(
    points: np.ndarray, corners: np.ndarray, name: str | None, normal: np.ndarray | None
) -> np.ndarray:
    """Planar coordinates exactly as a single-process projection of the whole scan makes
    them: the core projects onto a frame whose origin is the points' bounding-box centre,
    so the scan's two box corners ride along. O(n)."""
    uv, _ = _core.project(np.concatenate([points, corners]), name, normal)
    return uv[: len(points)]


def _part_plane_survey(part: Part, corners: np.ndarray, plane: tuple) -> dict[str, Any]:
    """A part's planar bounds and the median spacing of its first SPACING_SAMPLE points."""
    points, _ = load_part(part)
    uv = project_with_box(points, corners, *plane)
    head = uv[:SPACING_SAMPLE]
    try:
        faces, _ = _core.delaunay(np.ascontiguousarray(head))
        spacing = _core.median_spacing(head, faces)
    except (ScanmeshError, ValueError):
        spacing = math.nan
    return {
        "box": (uv[:, 0].min(), uv[:, 0].max(), uv[:, 1].min(), uv[:, 1].max()),
        "spacing": spacing,
    }


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
    :func:`_gated`, only waited for. Each tile reads its parts again (a part is read once
    per tile it meets), so that no part's bins wait in memory for a later tile."""
    points, lines = load_part(part)
    uv = project_with_box(points, corners, *plane)
    umin, umax, vmin, vmax = grid.region(tile)
    inside = (uv[:, 0] >= umin) & (uv[:, 0] <= umax) & (uv[:, 1] >= vmin) & (uv[:, 1] <= vmax)
    index = part.offset + np.flatnonzero(inside)
    return Bins(index, points[inside], uv[inside], lines[inside])


# ---------------------------------------------------------------------------------------
# Tiles (run on workers)


@dataclass
class Tile:
    """One tile's points (its region, sorted by global index) and triangulation."""

    tile: int
    index: np.ndarray
    points: np.ndarray
    uv: np.ndarray
    lines: np.ndarray
    own: np.ndarray  # (k,) bool: in this tile's cell
    faces: np.ndarray  # (m, 3) int64 local: untrimmed Delaunay, then trimmed
    nearest: np.ndarray  # sorted nearest-neighbour distances of own distinct points
    extent: float = 0.0
    meta: dict[str, Any] = field(default_factory=dict)


def _merge_bins(tile: int, grid: Grid, *bins: Bins) -> Tile:
    index = np.concatenate([b.index for b in bins]) if bins else np.zeros(0, np.int64)
    order = np.argsort(index, kind="stable")

    def cat(name: str, shape: tuple[int, ...], dtype: type) -> np.ndarray:
        if not bins:
            return np.zeros(shape, dtype)
        return np.concatenate([getattr(b, name) for b in bins])[order]

    uv = np.ascontiguousarray(cat("uv", (0, 2), np.float64))
    return Tile(
        tile=tile,
        index=index[order],
        points=np.ascontiguousarray(cat("points", (0, 3), np.float64)),
        uv=uv,
        lines=cat("lines", (0,), np.int64),
        own=grid.cells(uv) == tile,
        faces=np.zeros((0, 3), np.int64),
        nearest=np.zeros(0),
    )


def _triangulate(tile: int, grid: Grid, extent: float, *bins: Bins) -> Tile:
    """The tile's region triangulated (untrimmed) and its own points' nearest-neighbour
    distances along Delaunay edges, as the core's median_spacing takes them."""
    t = _merge_bins(tile, grid, *bins)
    if len(t.index) >= 3:
        try:
            t.faces, duplicate_of = _core.delaunay(t.uv)
        except ScanmeshError:  # all collinear or coincident: no triangle here
            duplicate_of = np.full(len(t.index), -1)
        t.meta["duplicates"] = int(np.count_nonzero((duplicate_of >= 0) & t.own))
    if len(t.faces):
        a = t.faces.ravel()
        b = np.roll(t.faces, -1, axis=1).ravel()
        d = np.hypot(*(t.uv[a] - t.uv[b]).T)
        keep = d > 1e-9 * extent  # trim::NEAR_DUPLICATE_RELATIVE of the scan's extent
        nearest = np.full(len(t.index), np.inf)
        np.minimum.at(nearest, a[keep], d[keep])
        np.minimum.at(nearest, b[keep], d[keep])
        mine = nearest[t.own]
        t.nearest = np.sort(mine[np.isfinite(mine)])
    return t


def _nearest_only(t: Tile) -> Tile:
    """The tile's nearest-neighbour distances alone (what the median search reads), so
    that its points and faces can go."""
    return Tile(
        tile=t.tile,
        index=np.zeros(0, np.int64),
        points=np.zeros((0, 3)),
        uv=np.zeros((0, 2)),
        lines=np.zeros(0, np.int64),
        own=np.zeros(0, bool),
        faces=np.zeros((0, 3), np.int64),
        nearest=t.nearest,
    )


def _count(t: Tile, values: np.ndarray, side: str) -> np.ndarray:
    """How many of the tile's distances are <= (side "right") or < ("left") each value."""
    return np.searchsorted(t.nearest, values, side=side)


def _values_inside(t: Tile, lo: float, hi: float, most: int) -> tuple[np.ndarray, int]:
    """The tile's distances in the open interval (lo, hi), at most ``most`` of them evenly
    by rank (the smallest always), and how many there are."""
    a = np.searchsorted(t.nearest, lo, side="right")
    b = np.searchsorted(t.nearest, hi, side="left")
    inside = t.nearest[a:b]
    if len(inside) <= most:
        return inside, len(inside)
    return inside[np.linspace(0, len(inside) - 1, most).astype(np.int64)], len(inside)


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


def _trim(t: Tile, grid: Grid, box: tuple[float, ...], limit: float) -> Tile:
    """Trims the tile's triangulation as the core trims the whole one, and marks the faces
    this tile owns (circumcentre in its cell) and whether they are certified. A new Tile:
    the input stays as it was, in case Dask runs this again."""
    faces = t.faces
    if len(faces):
        jumps = JUMP_FACTOR if math.isfinite(limit) else math.inf
        faces = _core.trim_long_edges(t.uv, faces, limit, t.points, jumps)
    centre, radius = circumcentres(t.uv, faces, t.index)
    owned = grid.cells(centre) == t.tile if len(faces) else np.zeros(0, bool)
    uncertified = np.count_nonzero(
        ~certified(centre[owned], radius[owned], grid.region(t.tile), box)
    )
    meta = {**t.meta, "owned": owned, "uncertified": int(uncertified)}
    return dataclasses.replace(t, faces=faces, nearest=np.zeros(0), meta=meta)


def _noise(t: Tile, frame: Frame, plane: PlaneSpec) -> tuple[float, float]:
    """(noise sigma or NaN, median planar edge) of the tile's region, as annealing's
    automatic tie tolerance measures them on a whole scan."""
    if not len(t.faces):
        return math.nan, math.nan
    scan = PlanarScan(points=t.points, uv=t.uv, frame=frame, line_ids=t.lines, plane=plane)
    try:
        sigma = noise(scan)
    except ScanmeshError:
        sigma = math.nan
    return sigma, median_edge(t.uv, t.faces)


def own_tac(t: Tile) -> np.ndarray:
    """tac of the tile's own interior vertices over its faces (their fans are whole in the
    tile). O(n + m)."""
    if not len(t.faces):
        return np.zeros(0)
    tac, _ = _core.mesh_quality(t.points, t.faces)
    return tac[t.own & ~np.isnan(tac)]


def face_block(t: Tile, faces: np.ndarray, uncertified: int) -> FaceBlock:
    """The faces (local indices) as a FaceBlock over global indices, with the quality sums
    of this tile's own vertices (their fans are complete in the tile) and of the faces."""
    sums: dict[str, float] = {
        "faces": float(len(faces)),
        "uncertified": float(uncertified),
        "duplicates": float(t.meta.get("duplicates", 0)),
    }
    mine = own_tac(t)
    if len(faces):
        _, min_angle = _core.mesh_quality(t.points, faces)
        deg = np.degrees(min_angle)
    else:
        deg = np.zeros(0)
    corners = t.points[faces]
    area = 0.5 * np.linalg.norm(
        np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1
    )
    sums.update(
        n_interior=float(len(mine)),
        tac_1=float(mine.sum()),
        tac_2_squared=float(np.square(mine).sum()),
        tac_inf=float(mine.max()) if len(mine) else 0.0,  # combine by max
        min_angle_deg=float(deg.min()) if len(deg) else math.inf,  # combine by min
        slivers=float(np.count_nonzero(deg < _core.SLIVER_ANGLE_DEG)),
        area=float(area.sum()),
    )
    return FaceBlock(vertices=t.points, local=faces, index=t.index, sums=sums)


def _delaunay_block(t: Tile) -> FaceBlock:
    owned = t.meta["owned"]
    return face_block(t, t.faces[owned], t.meta["uncertified"])


# ---------------------------------------------------------------------------------------
# LOP and annealing of pieces


def piece_faces(faces: np.ndarray, movable: np.ndarray) -> np.ndarray:
    """Flags of the faces whose three corners are movable, less those around vertices where
    such faces would touch only at a point (the core takes no pinched vertex). O(m)."""
    take = movable[faces].all(axis=1)
    while True:
        f = faces[take]
        if not len(f):
            return take
        n = int(faces.max()) + 1
        start = f.ravel()
        end = np.roll(f, -1, axis=1).ravel()
        key = start * n + end
        twin = np.isin(end * n + start, key)
        boundary_out = np.bincount(start[~twin], minlength=n)
        pinched = boundary_out > 1
        if not pinched.any():
            return take
        take &= ~pinched[faces].any(axis=1)


def optimize_piece(
    points: np.ndarray,
    uv: np.ndarray,
    faces: np.ndarray,
    movable: np.ndarray,
    method: str,
    params: dict[str, Any],
    seed: int,
) -> np.ndarray:
    """``faces`` with the piece of faces whose corners are all movable optimized by LOP or
    annealing; every other face unchanged. O(piece work)."""
    take = piece_faces(faces, movable) if len(faces) else np.zeros(0, bool)
    piece = faces[take]
    if len(piece) < 2:
        return faces
    used, local = np.unique(piece, return_inverse=True)
    local = local.reshape(piece.shape).astype(np.int64)
    pts, puv = np.ascontiguousarray(points[used]), np.ascontiguousarray(uv[used])
    if method == "lop":
        done, _ = _core.lop(
            pts,
            puv,
            local,
            params["criterion"],
            params["p"],
            params["sliver_guard"],
            params["tie_tolerance"],
        )
    else:
        # time_limit bounds each tile's pass (the tiles of a pass run side by side)
        native = {k: v for k, v in params.items() if k != "time_limit"}
        runner = _core.Annealer(pts, puv, local, seed=seed, **native)
        drive(runner, 0, False, params.get("time_limit"))
        done, _, _ = runner.finish()
    return np.concatenate([faces[~take], used[done]])


def _optimize_first(
    t: Tile, grid: Grid, method: str, params: dict[str, Any], seed: int, path: str
) -> dict[str, Any]:
    """Pass 1: optimizes the faces whose corners this tile owns; writes the faces this
    tile answers for (its piece, and the faces across cells whose circumcentre it holds)
    with their corners' data to ``path`` (.npz, through a temporary renamed at the end, so
    a rerun of the task replaces it whole), and returns the path with the tile's counts:
    the mesh waits for pass 2 on disk, not in a worker's memory."""
    faces = t.faces
    cell = grid.cells(t.uv)
    corner_cells = cell[faces] if len(faces) else np.zeros((0, 3), np.int64)
    inside = (corner_cells == t.tile).all(axis=1)
    mine = inside | (t.meta["owned"] & ~(corner_cells == corner_cells[:, :1]).all(axis=1))
    kept = faces[mine]
    # summed over tiles, the tiled Delaunay's tac_1 (as the "delaunay" method reports it)
    before = own_tac(t)
    done = optimize_piece(t.points, t.uv, kept, t.own, method, params, seed)
    used, local = np.unique(done, return_inverse=True)
    partial = f"{path}.{os.getpid()}.tmp"
    with open(partial, "wb") as handle:
        np.savez(
            handle,
            faces=t.index[used][local.reshape(done.shape)]
            if len(done)
            else np.zeros((0, 3), np.int64),
            index=t.index[used],
            points=t.points[used],
            uv=t.uv[used],
        )
    os.replace(partial, path)
    return {
        "path": path,
        "uncertified": t.meta["uncertified"],
        "duplicates": t.meta.get("duplicates", 0),
        "initial_tac_1": float(before.sum()),
    }


def _route(summary: dict[str, Any], grid: Grid, tile: int, counts: bool) -> dict[str, Any]:
    """The faces of a pass-1 tile (read from its file) that shifted tile ``tile`` owns a
    corner of; the pass-1 tile's counts when ``counts`` (true for exactly one shifted tile
    per pass-1 tile)."""
    with np.load(summary["path"]) as mesh:
        index, faces, points, uv = mesh["index"], mesh["faces"], mesh["points"], mesh["uv"]
    local = np.searchsorted(index, faces)
    take = (grid.cells(uv)[local] == tile).any(axis=1)
    used = np.unique(local[take])
    return {
        "faces": faces[take],
        "index": index[used],
        "points": points[used],
        "uv": uv[used],
        "uncertified": summary["uncertified"] if counts else 0,
        "duplicates": summary["duplicates"] if counts else 0,
        "initial_tac_1": summary["initial_tac_1"] if counts else 0.0,
    }


def _optimize_second(
    tile: int,
    grid: Grid,
    first: Grid,
    seam: float,
    method: str,
    params: dict[str, Any],
    seed: int,
    after: None,
    counts: tuple[bool, ...],
    *summaries: dict[str, Any],
) -> FaceBlock:
    """Pass 2 on a shifted tile: reads its share of the pass-1 tiles' meshes
    (``summaries``, with ``counts`` as :func:`_route` takes them), optimizes the faces
    within ``seam`` of pass 1's borders whose corners it owns, and returns the faces whose
    lowest-index corner it owns. ``after``: the gate of :func:`_gated`."""
    meshes = [_route(m, grid, tile, c) for m, c in zip(summaries, counts, strict=True)]
    index = np.concatenate([m["index"] for m in meshes]) if meshes else np.zeros(0, np.int64)
    index, first_at = np.unique(index, return_index=True)

    def cat(name: str, shape: tuple[int, ...]) -> np.ndarray:
        if not meshes:
            return np.zeros(shape)
        return np.ascontiguousarray(np.concatenate([m[name] for m in meshes])[first_at])

    points, uv = cat("points", (0, 3)), cat("uv", (0, 2))
    faces = np.concatenate([m["faces"] for m in meshes]) if meshes else np.zeros((0, 3), np.int64)
    faces = np.searchsorted(index, faces)
    own = grid.cells(uv) == tile
    movable = own & first.near_borders(uv, seam)
    faces = optimize_piece(points, uv, faces, movable, method, params, seed)
    t = Tile(
        tile=tile,
        index=index,
        points=points,
        uv=uv,
        lines=np.zeros(0, np.int64),
        own=own,
        faces=faces,
        nearest=np.zeros(0),
    )
    lowest = faces.min(axis=1) if len(faces) else np.zeros(0, np.int64)  # index is sorted
    t.meta["duplicates"] = sum(m["duplicates"] for m in meshes)
    block = face_block(t, faces[own[lowest]], sum(m["uncertified"] for m in meshes))
    block.sums["initial_tac_1"] = float(sum(m["initial_tac_1"] for m in meshes))
    return block


# ---------------------------------------------------------------------------------------
# The driver (runs on the client)


def _tile_seed(seed: int, phase: int, tile: int) -> int:
    return int(np.random.SeedSequence([seed, phase, tile]).generate_state(1, np.uint64)[0])


def check_tile_options(
    method: str, options: dict[str, Any]
) -> tuple[dict[str, Any], float | None, int]:
    """The method's options checked by its table entry; returns (params, max_edge, seed).
    ``initial`` must be "delaunay" (tiles start from the tiled Delaunay triangulation)."""
    if method not in METHODS:
        raise ParameterError(f"method {method!r} does not run in tiles; use one of {METHODS}")
    rest = dict(options)
    shared = {k: rest.pop(k) for k in ("max_edge", "seed", "lines") if k in rest}
    if "lines" in shared:
        raise ParameterError("lines= comes from the parts' files in a distributed run")
    params = TABLE[method].check(rest, shared)
    if params.pop("initial", "delaunay") != "delaunay":
        raise ParameterError(
            f"method {method!r} in tiles starts from initial='delaunay' only (got"
            f" {options.get('initial')!r})"
        )
    max_edge = shared.get("max_edge")
    seed = 0 if shared.get("seed") is None else SEED_OPTION.check(shared["seed"])
    if method == "anneal" and params.get("chains", 0) == 0:
        params["chains"] = 1  # automatic chains follow each piece's size, not the scan's
    return params, (None if max_edge is None else MAX_EDGE_OPTION.check(max_edge)), seed


def _resolve_plane(plane: PlaneSpec, sample: np.ndarray) -> tuple[str | None, np.ndarray | None]:
    """The plane as an axis name or a normal (never least squares over the whole scan)."""
    if plane is None:
        from scanmesh.plane_choice import choose_plane

        plane = choose_plane(sample).spec
    name, normal = plane_args(plane)
    if name == "best-fit":
        _, frame = _core.project(sample, "best-fit", None)
        return None, np.asarray(frame[3], dtype=np.float64)
    return name, normal


def _median_nearest(client: Any, tiles: list[Any], total: int) -> float:
    """The exact upper median (index total // 2 of the sorted values) of the tiles'
    nearest-neighbour distances, by rounds of counts: the client holds at most
    ``MEDIAN_SAMPLE`` values per tile at a time. Each round samples the values in an open
    interval known to hold the median and narrows it to two neighbouring samples, or finds
    the median among the samples' ties. O(rounds x tiles) round trips, a few in practice."""
    k = total // 2
    lo, hi = -math.inf, math.inf

    def counts(values: np.ndarray, side: str) -> np.ndarray:
        return sum(
            client.gather([client.submit(_count, t, values, side, pure=False) for t in tiles])
        )

    while True:
        found = client.gather(
            [client.submit(_values_inside, t, lo, hi, MEDIAN_SAMPLE, pure=False) for t in tiles]
        )
        below = int(counts(np.array([lo]), "right")[0]) if math.isfinite(lo) else 0
        if all(len(values) == n for values, n in found):
            merged = np.sort(np.concatenate([values for values, _ in found]))
            return float(merged[k - below])
        candidates = np.unique(np.concatenate([values for values, _ in found]))
        at_most, under = counts(candidates, "right"), counts(candidates, "left")
        hit = (under <= k) & (k < at_most)
        if hit.any():
            return float(candidates[np.argmax(hit)])
        j = int(np.searchsorted(at_most, k, side="right"))  # first with more than k at most
        lo = float(candidates[j - 1]) if j > 0 else lo
        hi = float(candidates[j]) if j < len(candidates) else hi


def tile_blocks(
    client: Any,
    parts: list[Part],
    method: str,
    options: dict[str, Any],
    *,
    plane: PlaneSpec,
    progress: bool | Callable[..., Any],
    scratch: Path | None = None,
    add: Callable[[Any], Any] | None = None,
) -> tuple[list[Any], dict[str, Any]]:
    """Delaunay, LOP or annealing of the scan in ``parts`` on the cluster, in tiles of the
    plane (rules in this module's docstring).

    Parameters
    ----------
    client : distributed.Client
    parts : list of Part
        The scan's parts, offsets consecutive from 0.
    method : "delaunay", "lop" or "anneal"
    options : dict
        The method's options as in :data:`scanmesh.methods.TABLE` (``initial`` must be
        "delaunay"), plus the shared keywords ``max_edge`` and ``seed``.
    plane : None, "best-fit", "x", "y", "z" or (3,) float
        The projection plane; None chooses it on a seeded sample of the parts.
    progress : bool or callable
        Anything true shows Dask's progress bar (``distributed.progress``) for each run
        through the tiles as it is waited on.
    scratch : Path, optional
        A folder every worker sees, for pass 1's meshes (LOP and annealing); None: a
        temporary folder of this machine, removed on return (a LocalCluster's workers
        see it).
    add : callable, optional
        Called on each tile's block future as soon as it is submitted (the output's
        writer, :meth:`StreamedMesh.add`), returning a future of something small: the
        tiles in flight are counted up to it, so that the blocks do not pile up.

    Returns
    -------
    blocks : list of distributed.Future
        One per tile, in order: ``add``'s futures, or the :class:`FaceBlock` futures when
        ``add`` is None. Every one is done on return.
    info : dict
        "tiles" (of the first pass), "max_edge" (the trimming length used); for annealing
        also "tie_tolerance" and, when it was automatic, "noise" (the median over tiles of
        :func:`scanmesh.noise` of each tile's region, None when no tile has enough points
        for an estimate). LOP's and annealing's blocks also sum "initial_tac_1": the tiled
        Delaunay triangulation's tac_1 before optimizing.
    """
    params, max_edge, seed = check_tile_options(method, options)
    if not parts:
        raise ParameterError("no parts to triangulate")

    def wait(futures: list[Any]) -> None:
        """Until the futures are done (pass 2 reads pass 1's files, removed on return),
        with Dask's progress bar when asked; raises a task's error."""
        import distributed

        if progress:
            distributed.progress(futures)
        distributed.wait(futures)
        bad = [f for f in futures if f.status == "error"]
        if bad:
            bad[0].result()

    share = max(1, SAMPLE_POINTS // len(parts))
    surveys = client.gather(
        [client.submit(_part_survey, p, share, seed, pure=False) for p in parts]
    )
    total = sum(s["count"] for s in surveys)
    lo = np.min([s["lo"] for s in surveys], axis=0)
    hi = np.max([s["hi"] for s in surveys], axis=0)
    corners = np.stack([lo, hi])
    sample = np.concatenate([s["sample"] for s in surveys])
    plane_spec = _resolve_plane(plane, sample)
    surveys2 = client.gather(
        [client.submit(_part_plane_survey, p, corners, plane_spec, pure=False) for p in parts]
    )
    boxes = [s["box"] for s in surveys2]
    box = (
        min(b[0] for b in boxes),
        max(b[1] for b in boxes),
        min(b[2] for b in boxes),
        max(b[3] for b in boxes),
    )
    extent = max(box[1] * 0.5 - box[0] * 0.5, box[3] * 0.5 - box[2] * 0.5)
    spacing = float(np.nanmedian([s["spacing"] for s in surveys2]))
    if max_edge is not None and math.isfinite(max_edge):
        reach = max_edge
    else:
        reach = MAX_EDGE_FACTOR * (spacing if math.isfinite(spacing) else extent * 1e-3)
    grid = make_grid(box, total, BAND_EDGES * reach)

    part_tiles = [set(grid.tiles_meeting(b)) for b in boxes]
    own_scratch = scratch is None
    folder = Path(tempfile.mkdtemp(prefix="scanmesh-tiles-")) if scratch is None else scratch
    try:
        return _tile_stages(
            client,
            parts,
            part_tiles,
            method,
            params,
            seed,
            plane_spec,
            corners,
            lo,
            hi,
            grid,
            box,
            extent,
            reach,
            max_edge,
            folder,
            add,
            wait,
        )
    finally:
        if own_scratch:
            shutil.rmtree(folder, ignore_errors=True)


def _after(*_: Any) -> None:
    """A gate: done once its arguments are (see :func:`_gated`)."""
    return None


def _gated(
    client: Any, run: str, count: int, chain: Callable[[int, Any, Callable[[str], str]], Any]
) -> list[Any]:
    """Runs ``chain(t, gate, key)`` for t < count: it submits tile t's tasks, its first
    ones taking ``gate`` as an argument, each with the key ``key(stage)`` (naming the run,
    the stage and the tile), and returns the future of the tile's last, small result.
    Tile t's gate is done when tile t - k's last result is, with k TILES_PER_THREAD x the
    cluster's threads: at most k tiles are in flight, one starting as one ends, while the
    scheduler sees every task (faults and progress as usual). Returns the last results'
    futures, in tile order."""
    k = TILES_PER_THREAD * max(1, sum(client.nthreads().values()))
    finals: list[Any] = []
    gates: list[Any] = []
    for t in range(count):

        def key(stage: str, t: int = t) -> str:
            return f"scanmesh-tile-{run}-{stage}-{t}-{uuid.uuid4().hex}"

        finals.append(chain(t, gates[t - k] if t >= k else None, key))
        gates.append(client.submit(_after, finals[t], key=key("gate")))
    return finals


def _tile_stages(
    client: Any,
    parts: list[Part],
    part_tiles: list[set[int]],
    method: str,
    params: dict[str, Any],
    seed: int,
    plane_spec: tuple,
    corners: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    grid: Grid,
    box: tuple[float, float, float, float],
    extent: float,
    reach: float,
    max_edge: float | None,
    folder: Path,
    add: Callable[[Any], Any] | None,
    wait: Callable[[list[Any]], None],
) -> tuple[list[Any], dict[str, Any]]:
    """The stages of :func:`tile_blocks` from the binning on, each run through the tiles
    by :func:`_gated`."""

    Key = Callable[[str], str]

    def triangulated(t: int, gate: Any, key: Key) -> Any:
        bins = [
            client.submit(_bin_part, p, corners, plane_spec, grid, t, gate, key=key("bin"))
            for i, p in enumerate(parts)
            if t in part_tiles[i]
        ]
        return client.submit(_triangulate, t, grid, extent, *bins, key=key("triangulate"))

    def trimmed(t: int, gate: Any, key: Key, limit: float) -> Any:
        return client.submit(_trim, triangulated(t, gate, key), grid, box, limit, key=key("trim"))

    def emit(block: Any) -> Any:
        return add(block) if add is not None else block

    if max_edge is None:
        # the exact median spacing over the tiles' own nearest-neighbour distances: a
        # first run through the tiles keeps only those distances (8 bytes per point)
        nearest = _gated(
            client,
            "nearest",
            grid.count,
            lambda t, gate, key: client.submit(
                _nearest_only, triangulated(t, gate, key), key=key("nearest")
            ),
        )
        wait(nearest)
        counts = client.gather([client.submit(lambda t: len(t.nearest), t) for t in nearest])
        limit = MAX_EDGE_FACTOR * _median_nearest(client, nearest, sum(counts))
        del nearest
    else:
        limit = max_edge
    info: dict[str, Any] = {"tiles": grid.count, "max_edge": limit}
    if method == "delaunay":
        blocks = _gated(
            client,
            "delaunay",
            grid.count,
            lambda t, gate, key: emit(
                client.submit(_delaunay_block, trimmed(t, gate, key, limit), key=key("block"))
            ),
        )
        wait(blocks)
        return blocks, info
    if method == "anneal" and params.get("tie_tolerance") is None:
        # annealing's automatic tie tolerance from the scan's noise, the median over tiles
        # of their estimates (reported; one process reports noise.noise of the whole
        # scan), and the median of the tiles' median edges (noise.noise_tolerance on one
        # scan). A given tie tolerance skips this O(N log N) run through the tiles, and
        # reports no noise.
        frame = Frame(*_core.project(np.stack([lo, hi, lo * 0.5 + hi * 0.5]), *plane_spec)[1])
        spec = plane_spec[0] if plane_spec[0] is not None else plane_spec[1]
        measured = np.array(
            client.gather(
                _gated(
                    client,
                    "noise",
                    grid.count,
                    lambda t, gate, key: client.submit(
                        _noise, trimmed(t, gate, key, limit), frame, spec, key=key("noise")
                    ),
                )
            )
        )
        sigma, edge = (
            np.nanmedian(measured, axis=0) if np.isfinite(measured).any() else (math.nan, math.nan)
        )
        info["noise"] = float(sigma) if math.isfinite(sigma) else None
        floor = float(ANNEAL_DEFAULTS["tie_tolerance"])
        params["tie_tolerance"] = (
            tie_tolerance(sigma, edge, params["p"], floor) if math.isfinite(sigma) else floor
        )
    if method == "anneal":
        info["tie_tolerance"] = params["tie_tolerance"]
    first = _gated(
        client,
        "first",
        grid.count,
        lambda t, gate, key: client.submit(
            _optimize_first,
            trimmed(t, gate, key, limit),
            grid,
            method,
            params,
            _tile_seed(seed, 0, t),
            str(folder / f"pass1_{t:06d}.npz"),
            key=key("optimize"),
        ),
    )
    wait(first)
    second_grid = grid.shifted()
    meets = [second_grid.tiles_meeting(grid.region(i)) for i in range(grid.count)]
    seam = SEAM_EDGES * limit if math.isfinite(limit) else SEAM_EDGES * reach

    def second(s: int, gate: Any, key: Key) -> Any:
        sources = [i for i in range(grid.count) if s in meets[i]]
        block = client.submit(
            _optimize_second,
            s,
            second_grid,
            grid,
            seam,
            method,
            params,
            _tile_seed(seed, 1, s),
            gate,
            tuple(s == meets[i][0] for i in sources),  # each pass-1 tile's counts go once
            *[first[i] for i in sources],
            key=key("optimize"),
        )
        return emit(block)

    blocks = _gated(client, "second", second_grid.count, second)
    wait(blocks)
    return blocks, info
