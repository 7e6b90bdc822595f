"""A virtual digitizer: parallel scan lines of rays cast from above onto a triangle mesh.

A CAD model scanned this way gives scan-line points whose true surface is known exactly,
so a reconstruction's height error can be measured (docs/definitions.md, "Judging a mesh
against the true part").

All rays are parallel (direction ``-up``) and start on a regular grid, so casting them is
an orthographic z-buffer: each triangle is tested only against the grid nodes inside its
projected bounding box (integer arithmetic, no search tree), in vectorized chunks, with the
hit height interpolated in float64 from the triangle's corners. The same routine,
:func:`cast_grid`, rasterizes meshes for :mod:`scanmesh.present.render`.

Frame: ``along`` (lines run this way), ``across = up x along`` (lines are stacked this way)
and ``up`` form a right-handed frame; seen from above, ``along`` points right and
``across`` points up the page, like x and y on a map.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from scanmesh._checks import POSITIVE, Option
from scanmesh.errors import InvalidMeshError, ParameterError
from scanmesh.formats.mesh import load_mesh
from scanmesh.formats.points import ScanPoints
from scanmesh.scan.axes import AxisSpec, scan_frame

if TYPE_CHECKING:
    import trimesh

#: Grid nodes tested per vectorized chunk (bounds memory: about 150 bytes per node).
CHUNK_NODES = 1 << 19

#: Inclusion tolerance of the point-in-triangle test, relative to the model's size: a node
#: on an edge shared by two triangles must not fall through the crack between them.
EDGE_TOL = 1e-12

#: How close ``n_points`` must come (relative) before the spacing search stops early.
N_POINTS_RTOL = 0.002


def cast_grid(
    tri_uv: np.ndarray,
    tri_h: np.ndarray,
    origin: tuple[float, float],
    step: tuple[float, float],
    shape: tuple[int, int],
    tol: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Cast parallel rays from +h down onto triangles; keep the highest hit of each ray.

    Ray (i, j) passes through the plane point ``origin + (i * step[0], j * step[1])``.

    Parameters
    ----------
    tri_uv : (F, 3, 2) float
        Triangle corners in the plane of the grid.
    tri_h : (F, 3) float
        Corner heights (the coordinate against the ray direction).
    origin, step : (2,) float
        Grid origin and spacing (steps > 0).
    shape : (ni, nj) int
        Nodes along the first and second plane axis.
    tol : float
        A node up to this distance outside a triangle still counts as inside it (so that
        nodes on shared edges never fall through); its height is the extrapolated plane.

    Returns
    -------
    height : (nj * ni,) float64
        Highest hit of each ray, row-major by j then i; ``-inf`` where the ray misses.
    face : (nj * ni,) int64
        Index of the triangle hit, ``-1`` where the ray misses.
    """
    ni, nj = int(shape[0]), int(shape[1])
    height = np.full(ni * nj, -np.inf)
    face = np.full(ni * nj, -1, dtype=np.int64)
    if ni <= 0 or nj <= 0 or len(tri_uv) == 0:
        return height, face
    p = np.asarray(tri_uv, dtype=np.float64)
    h = np.asarray(tri_h, dtype=np.float64)
    # corner coordinates as contiguous columns (reductions over a length-3 axis are slow)
    x = [np.ascontiguousarray(p[:, m, 0]) for m in range(3)]
    y = [np.ascontiguousarray(p[:, m, 1]) for m in range(3)]
    # twice the signed projected area; triangles seen edge-on can not be hit
    area2 = (x[1] - x[0]) * (y[2] - y[0]) - (y[1] - y[0]) * (x[2] - x[0])
    # row ranges of each triangle, widened by the tolerance
    y_lo = np.minimum(np.minimum(y[0], y[1]), y[2])
    y_hi = np.maximum(np.maximum(y[0], y[1]), y[2])
    lo_j = np.clip(np.ceil((y_lo - tol - origin[1]) / step[1]), 0, nj).astype(np.int64)
    hi_j = np.clip(np.floor((y_hi + tol - origin[1]) / step[1]), -1, nj - 1).astype(np.int64)
    x_lo = np.minimum(np.minimum(x[0], x[1]), x[2])
    x_hi = np.maximum(np.maximum(x[0], x[1]), x[2])
    in_i = (x_hi + tol >= origin[0]) & (x_lo - tol <= origin[0] + (ni - 1) * step[0])
    rows = np.maximum(hi_j - lo_j + 1, 0)
    live = np.flatnonzero((rows > 0) & in_i & (area2 != 0.0))
    if len(live) == 0:
        return height, face
    # orient every live triangle counter-clockwise (swap corners 1 and 2 of clockwise ones)
    # so that inside means all three edge functions >= 0; arrays below are (3, L)
    flip = area2[live] < 0
    swap = ((0, 0), (1, 2), (2, 1))  # (corner, corner taken when flipped)
    cx = np.array([np.where(flip, x[b][live], x[a][live]) for a, b in swap])
    cy = np.array([np.where(flip, y[b][live], y[a][live]) for a, b in swap])
    hh = [np.ascontiguousarray(h[live, m]) for m in range(3)]
    hh[1], hh[2] = np.where(flip, hh[2], hh[1]), np.where(flip, hh[1], hh[2])
    # edge m runs from corner m+1 to corner m+2 (opposite corner m); its length scales tol
    bx, by = np.roll(cx, -1, axis=0), np.roll(cy, -1, axis=0)
    ex, ey = np.roll(cx, -2, axis=0) - bx, np.roll(cy, -2, axis=0) - by
    slack = -tol * np.hypot(ex, ey)
    # two levels of flat numbering, each walked in chunks: (triangle, row) pairs, then the
    # nodes of each pair's span (the row's stretch inside the triangle)
    for k, off in _chunks(rows[live]):
        j = lo_j[live[k]] + off
        span_lo, span_hi = _row_span(cx[:, k], cy[:, k], origin[1] + j * step[1], tol)
        lo_i = np.clip(np.ceil((span_lo - tol - origin[0]) / step[0]), 0, ni).astype(np.int64)
        hi_i = np.clip(np.floor((span_hi + tol - origin[0]) / step[0]), -1, ni - 1)
        span = np.maximum(hi_i.astype(np.int64) - lo_i + 1, 0)
        for r, col in _chunks(span):
            kk = k[r]
            i = lo_i[r] + col
            jj = j[r]
            qu = origin[0] + i * step[0]
            qv = origin[1] + jj * step[1]
            # w_m: twice the area of (q, corner m+1, corner m+2), the weight of corner m
            w = [ex[m, kk] * (qv - by[m, kk]) - ey[m, kk] * (qu - bx[m, kk]) for m in range(3)]
            inside = (w[0] >= slack[0, kk]) & (w[1] >= slack[1, kk]) & (w[2] >= slack[2, kk])
            if not inside.any():
                continue
            w0, w1, w2 = (wm[inside] for wm in w)
            ki = kk[inside]
            h0 = hh[0][ki]
            # relative to corner 0, so a level triangle gives its height exactly
            rise = w1 * (hh[1][ki] - h0) + w2 * (hh[2][ki] - h0)
            hit_h = h0 + rise / (w0 + w1 + w2)
            ray = jj[inside] * ni + i[inside]
            np.maximum.at(height, ray, hit_h)
            top = hit_h >= height[ray]
            face[ray[top]] = live[ki[top]]
    return height, face


def _chunks(counts: np.ndarray):
    """Walk ``sum(counts)`` items in chunks of at most CHUNK_NODES.

    Yields (owner, offset): (n,) int64 arrays, item number ``offset`` of owner ``owner``.
    """
    ends = np.cumsum(counts)
    if len(ends) == 0:
        return
    starts = ends - counts
    total = int(ends[-1])
    for first in range(0, total, CHUNK_NODES):
        flat = np.arange(first, min(first + CHUNK_NODES, total), dtype=np.int64)
        owner = np.searchsorted(ends, flat, side="right")
        yield owner, flat - starts[owner]


def _row_span(
    xs: np.ndarray, ys: np.ndarray, y: np.ndarray, tol: float
) -> tuple[np.ndarray, np.ndarray]:
    """x extent of triangles (corners xs, ys: (3, n)) in the bands ``y - tol .. y + tol``.

    Returns (n,) lower and upper ends; an empty band gives (inf, -inf).
    """
    lo = np.full(len(y), np.inf)
    hi = np.full(len(y), -np.inf)
    for m in range(3):  # corners inside the band
        near = np.abs(ys[m] - y) <= tol
        lo = np.where(near, np.minimum(lo, xs[m]), lo)
        hi = np.where(near, np.maximum(hi, xs[m]), hi)
    lines = (y - tol, y + tol) if tol > 0 else (y,)
    for m in range(3):  # edges crossing the band's border lines
        x0, y0, x1, y1 = xs[m], ys[m], xs[(m + 1) % 3], ys[(m + 1) % 3]
        dy = y1 - y0
        flat = dy == 0
        dy = np.where(flat, 1.0, dy)
        for line in lines:
            t = (line - y0) / dy
            ok = ~flat & (t >= 0) & (t <= 1)
            xc = x0 + t * (x1 - x0)
            lo = np.where(ok, np.minimum(lo, xc), lo)
            hi = np.where(ok, np.maximum(hi, xc), hi)
    return lo, hi


def _grid_axis(lo: float, hi: float, step: float) -> tuple[float, int]:
    """First node and node count of a grid with this step, centred on [lo, hi]."""
    count = int(math.floor((hi - lo) / step + 1e-9)) + 1
    return lo + 0.5 * ((hi - lo) - (count - 1) * step), count


#: The largest angle between a face and the ray that still returns a sample (degrees).
GRAZING_OPTION = Option(
    "grazing",
    "float",
    90.0,
    "largest angle of a sampled face to the ray (degrees)",
    low=0.0,
    low_open=True,
    high=90.0,
)


class _Scanner:
    """One mesh in one scanning frame, scanned at any spacing."""

    def __init__(self, mesh: trimesh.Trimesh, frame: np.ndarray) -> None:
        self.frame = frame
        local = np.asarray(mesh.vertices, dtype=np.float64) @ frame.T  # (V, 3) along/across/up
        tri = local[np.asarray(mesh.faces, dtype=np.int64)]  # (F, 3, 3)
        self.tri_uv = tri[..., :2]
        self.tri_h = tri[..., 2]
        self.lo = local.min(axis=0)
        self.hi = local.max(axis=0)
        self.scale = float(np.max(self.hi - self.lo)) or 1.0
        #: (rays,) int64 triangle each ray of the last cast hit (-1: none)
        self.last_face = np.empty(0, dtype=np.int64)

    def grid(self, spacing: float, line_spacing: float) -> tuple[float, int, float, int]:
        a0, na = _grid_axis(self.lo[0], self.hi[0], spacing)
        c0, nc = _grid_axis(self.lo[1], self.hi[1], line_spacing)
        return a0, na, c0, nc

    def cast(self, spacing: float, line_spacing: float) -> tuple[np.ndarray, tuple]:
        a0, na, c0, nc = grid = self.grid(spacing, line_spacing)
        if na * nc > 200_000_000:
            raise ParameterError(
                f"spacing {spacing:g} / line_spacing {line_spacing:g} would cast "
                f"{na * nc:,} rays over a part {self.scale:g} across; use a larger spacing"
            )
        height, face = cast_grid(
            self.tri_uv,
            self.tri_h,
            (a0, c0),
            (spacing, line_spacing),
            (na, nc),
            tol=EDGE_TOL * self.scale,
        )
        self.last_face = face
        return height, grid

    def facing(self, face: np.ndarray) -> np.ndarray:
        """(n,) float64 |cos| of the angle between the ray and the normal of each hit
        triangle ``face`` (indices into the mesh; -1 for a table hit gives 1)."""
        tri = np.concatenate([self.tri_uv, self.tri_h[..., None]], axis=2)[np.maximum(face, 0)]
        normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        length = np.linalg.norm(normal, axis=1)
        cos = np.abs(normal[:, 2]) / np.where(length > 0, length, 1.0)
        return np.where(face < 0, 1.0, cos)


def simulate_scan(
    mesh_or_path: trimesh.Trimesh | str | os.PathLike,
    *,
    up: AxisSpec = "z",
    along: AxisSpec = "x",
    spacing: float | None = None,
    line_spacing: float | None = None,
    n_points: int | None = None,
    noise: float = 0.0,
    table: bool = False,
    seed: int | np.random.Generator | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Scan a mesh with parallel lines of rays from above, like a line digitizer.

    Lines run along ``along`` and are stacked across ``up x along``; every ray points down
    (``-up``) and keeps its first hit. The grid covers the part's bounding box seen from
    above, centred on it.

    Parameters
    ----------
    mesh_or_path : trimesh.Trimesh or path
        The part (any mesh file trimesh reads).
    up : "x", "-y", ... or (3,) float
        The direction the digitizer looks from (rays travel along ``-up``).
    along : "x", "-y", ... or (3,) float
        The direction scan lines run; its component along ``up`` is ignored.
    spacing : float, optional
        Step between points along a line. Default: 1/100 of the part's larger extent
        across ``up``, unless ``n_points`` is given.
    line_spacing : float, optional
        Distance between lines (default: ``spacing``).
    n_points : int, optional
        Pick the spacing (with ``line_spacing`` following it unless given) so that the
        scan has about this many points; cannot be combined with ``spacing``.
    noise : float
        Standard deviation of Gaussian measurement noise along the ray (model units).
    table : bool
        False: rays that miss the part are dropped. True: they touch the plane under the
        part (its lowest point along ``up``), as a tactile probe touches the table.
    seed : int or numpy Generator, optional
        Seeds the noise.

    Returns
    -------
    points : (N, 3) float64
        Hits in the model's coordinates, line by line, each line in +``along`` order.
    line_ids : (N,) int64
        Line of each point, 0..L-1 in stacking order (lines without hits are skipped).
    """
    scan = simulate_range_scan(
        mesh_or_path,
        up=up,
        along=along,
        spacing=spacing,
        line_spacing=line_spacing,
        n_points=n_points,
        noise=noise,
        table=table,
        seed=seed,
    )
    assert scan.line_ids is not None
    return scan.points, scan.line_ids


def simulate_range_scan(
    mesh_or_path: trimesh.Trimesh | str | os.PathLike,
    *,
    up: AxisSpec = "z",
    along: AxisSpec = "x",
    spacing: float | None = None,
    line_spacing: float | None = None,
    n_points: int | None = None,
    noise: float = 0.0,
    table: bool = False,
    seed: int | np.random.Generator | None = None,
    grazing: float = 90.0,
) -> ScanPoints:
    """:func:`simulate_scan` with what a range scanner knows besides the points: the grid of
    rays (``ScanPoints.grid``: row = scan line, column = position along the lines) and the
    direction the rays came from (``ScanPoints.up``), so that the grid triangulation and the
    curtain report can use the line of sight. ``grazing`` (degrees, in (0, 90]) drops the
    samples on faces turned more than this from the ray, as a real scanner loses its
    returns at grazing angles (the noise is drawn before the dropout, so the kept points
    are those of the same scan without it). The same points and line ids as
    :func:`simulate_scan` for ``grazing=90``; ``ScanPoints.source`` is
    ``Path("simulated")``."""

    spacing = None if spacing is None else POSITIVE.check(spacing, "spacing")
    line_spacing = None if line_spacing is None else POSITIVE.check(line_spacing, "line_spacing")
    noise_f = float(noise) if isinstance(noise, (int, float, np.floating, np.integer)) else None
    if noise_f is None or not math.isfinite(noise_f) or noise_f < 0.0:
        raise ParameterError(f"noise must be a finite number >= 0, got {noise!r}")
    if n_points is not None:
        if isinstance(n_points, bool) or not isinstance(n_points, (int, np.integer)):
            raise ParameterError(f"n_points must be an integer, got {n_points!r}")
        if n_points < 1:
            raise ParameterError(f"n_points must be at least 1, got {n_points}")
        if spacing is not None:
            raise ParameterError("give spacing or n_points, not both")
    frame = scan_frame(up, along)
    mesh = load_mesh(mesh_or_path)
    scanner = _Scanner(mesh, frame)

    if spacing is None and n_points is None:
        spacing = float(max(scanner.hi[0] - scanner.lo[0], scanner.hi[1] - scanner.lo[1])) / 100
        if spacing <= 0:
            raise InvalidMeshError("the part has no extent across the scanning direction")
    if n_points is not None:
        spacing, height, grid = _search_spacing(scanner, int(n_points), line_spacing, table)
    else:
        height, grid = scanner.cast(spacing, line_spacing or spacing)
    a0, na, c0, nc = grid
    step_c = line_spacing or spacing

    grazing_f = GRAZING_OPTION.check(grazing)
    hit = np.isfinite(height)
    if table:
        height = np.where(hit, height, scanner.lo[2])
        hit = np.ones_like(hit)
    ray = np.flatnonzero(hit)
    i = ray % na
    j = ray // na
    local = np.column_stack((a0 + i * spacing, c0 + j * step_c, height[ray]))
    points = local @ frame  # back to model coordinates (exact for named axes)
    if noise_f > 0.0:
        rng = np.random.default_rng(seed)
        points = points - rng.normal(0.0, noise_f, size=len(points))[:, None] * frame[2]
    keep = np.ones(len(ray), dtype=bool)
    if grazing_f < 90.0:
        keep = scanner.facing(scanner.last_face[ray]) >= math.cos(math.radians(grazing_f))
    points, i, j = points[keep], i[keep], j[keep]
    rows, line_ids = np.unique(j, return_inverse=True)
    cells = np.full((len(rows), na), -1, dtype=np.int64)
    cells[line_ids, i] = np.arange(len(points))
    return ScanPoints(
        points=np.ascontiguousarray(points),
        line_ids=line_ids.astype(np.int64),
        source=Path("simulated"),
        extra={"format": "simulated range scan", "spacing": spacing, "line_spacing": step_c},
        grid=cells,
        up=frame[2],
    )


#: The six axis directions a part is scanned from for :func:`axis_views`.
AXIS_DIRECTIONS = ("x", "-x", "y", "-y", "z", "-z")


def axis_views(
    mesh: trimesh.Trimesh,
    spacing: float,
    *,
    noise: float = 0.0,
    grazing: float = 90.0,
    seed: int = 0,
) -> list[ScanPoints]:
    """The part seen from the six axis directions (:data:`AXIS_DIRECTIONS`), one
    :func:`simulate_range_scan` each, lines along x (along y when looking along x), view k
    seeded ``seed + k``: the input of :func:`scanmesh.merge` in its tests and benchmark."""
    return [
        simulate_range_scan(
            mesh,
            up=up,
            along="y" if up.strip("-") == "x" else "x",
            spacing=spacing,
            noise=noise,
            seed=seed + k,
            grazing=grazing,
        )
        for k, up in enumerate(AXIS_DIRECTIONS)
    ]


def _search_spacing(
    scanner: _Scanner, n_points: int, line_spacing: float | None, table: bool
) -> tuple[float, np.ndarray, tuple]:
    """Find a spacing whose scan has about ``n_points`` hits; return it with that scan.

    Hits scale like 1 / spacing**2 (1 / spacing with a fixed line spacing), but the part's
    footprint is not its bounding box, so the estimate is refined by scanning.
    """
    power = 1.0 if line_spacing is not None else 2.0
    ext_a, ext_c = (float(x) for x in scanner.hi[:2] - scanner.lo[:2])
    if ext_a <= 0 or ext_c <= 0:
        raise InvalidMeshError("the part has no extent across the scanning direction")
    if line_spacing is None:
        spacing = math.sqrt(ext_a * ext_c / n_points)  # as if the footprint were the box
    else:
        spacing = ext_a / max(n_points / (ext_c / line_spacing + 1.0) - 1.0, 1.0)
    best = None
    for _ in range(16):
        height, grid = scanner.cast(spacing, line_spacing or spacing)
        hits = len(height) if table else int(np.isfinite(height).sum())
        miss = abs(hits - n_points) / n_points
        if best is None or miss < best[0]:
            best = (miss, spacing, height, grid, scanner.last_face)
        if miss <= N_POINTS_RTOL or (hits == 0 and spacing < 1e-9 * scanner.scale):
            break
        spacing *= (max(hits, 1) / n_points) ** (1.0 / power)
    _, spacing, height, grid, scanner.last_face = best
    return spacing, height, grid
