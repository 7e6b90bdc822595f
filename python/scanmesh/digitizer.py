"""A virtual digitizer: parallel scan lines of rays cast from above onto a triangle mesh.

A CAD model scanned this way gives scan-line points whose true surface is known exactly,
so a reconstruction's height error can be measured (DESIGN.md, "How quality is judged").

All rays are parallel (direction ``-up``) and start on a regular grid, so casting them is
an orthographic z-buffer: each triangle is tested only against the grid nodes inside its
projected bounding box (integer arithmetic, no search tree), in vectorized chunks, with the
hit height interpolated in float64 from the triangle's corners. The same routine,
:func:`cast_grid`, rasterizes meshes for :mod:`scanmesh.render`.

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
from numpy.typing import ArrayLike

from scanmesh.errors import FileFormatError, InvalidMeshError, ParameterError

if TYPE_CHECKING:
    import trimesh

#: An axis: "x", "+y", "-z" (any case), or a 3-vector.
AxisSpec = str | ArrayLike

#: Grid nodes tested per vectorized chunk (bounds memory: about 150 bytes per node).
CHUNK_NODES = 1 << 19

#: Inclusion tolerance of the point-in-triangle test, relative to the model's size: a node
#: on an edge shared by two triangles must not fall through the crack between them.
EDGE_TOL = 1e-12

#: How close ``n_points`` must come (relative) before the spacing search stops early.
N_POINTS_RTOL = 0.002

_AXES = {"x": 0, "y": 1, "z": 2}


def parse_axis(spec: AxisSpec, name: str) -> np.ndarray:
    """Return an axis given as "x", "-y", "+Z" or a 3-vector as a (3,) float64 unit vector."""
    if isinstance(spec, str):
        text = spec.strip().lower()
        sign = 1.0
        if text[:1] in "+-" and text:
            sign = -1.0 if text[0] == "-" else 1.0
            text = text[1:]
        if text not in _AXES:
            raise ParameterError(
                f"{name} must be an axis name ('x', 'y', 'z', optionally signed like '-y') "
                f"or a 3-vector, got {spec!r}"
            )
        vec = np.zeros(3)
        vec[_AXES[text]] = sign
        return vec
    try:
        vec = np.asarray(spec, dtype=np.float64).ravel()
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be an axis name or a 3-vector, got {spec!r}") from None
    if vec.shape != (3,):
        raise ParameterError(f"{name} vector must have 3 components, got {vec.shape[0]}")
    length = float(np.linalg.norm(vec))
    if not np.all(np.isfinite(vec)) or length == 0.0:
        raise ParameterError(f"{name} vector must be finite and non-zero, got {vec.tolist()}")
    return vec / length


def scan_frame(up: AxisSpec = "z", along: AxisSpec = "x") -> np.ndarray:
    """The scanning frame as a (3, 3) float64 matrix with rows ``along``, ``across``, ``up``.

    ``along`` loses its component along ``up`` (so it need not be exactly perpendicular),
    but may not be parallel to it. For named axes the rows hold only 0 and +-1, so frame
    coordinates convert back to the model's without rounding.
    """
    u = parse_axis(up, "up")
    a = parse_axis(along, "along")
    a = a - np.dot(a, u) * u
    norm = float(np.linalg.norm(a))
    if norm < 1e-9:
        raise ParameterError(
            f"along ({along!r}) is parallel to up ({up!r}): scan lines need a direction "
            "across the scanning direction"
        )
    a = a / norm
    c = np.cross(u, a)
    return np.array([a, c, u])


def load_mesh(mesh_or_path: trimesh.Trimesh | str | os.PathLike) -> trimesh.Trimesh:
    """Return a ``trimesh.Trimesh`` from a mesh object or a mesh file (STL, PLY, OBJ, OFF, ...).

    Raises FileFormatError for a missing, unreadable or empty file and InvalidMeshError for
    a mesh object without triangles.
    """
    import trimesh

    if isinstance(mesh_or_path, (str, os.PathLike)):
        path = Path(mesh_or_path)
        if not path.is_file():
            raise FileFormatError(f"mesh file {path} does not exist")
        if path.stat().st_size == 0:
            raise FileFormatError(f"mesh file {path} is empty")
        try:
            mesh = trimesh.load_mesh(path)
        except Exception as exc:  # trimesh raises many kinds for bad files
            raise FileFormatError(f"cannot read mesh file {path}: {exc}") from None
        if isinstance(mesh, trimesh.Scene):
            mesh = mesh.to_mesh() if mesh.geometry else trimesh.Trimesh()
        if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
            raise FileFormatError(f"mesh file {path} holds no triangles")
        return mesh
    if isinstance(mesh_or_path, trimesh.Scene):
        mesh_or_path = mesh_or_path.to_mesh() if mesh_or_path.geometry else trimesh.Trimesh()
    if not isinstance(mesh_or_path, trimesh.Trimesh):
        raise ParameterError(
            f"expected a trimesh.Trimesh or a mesh file path, got {type(mesh_or_path).__name__}"
        )
    if len(mesh_or_path.faces) == 0:
        raise InvalidMeshError("the mesh has no triangles")
    if not np.all(np.isfinite(mesh_or_path.vertices)):
        raise InvalidMeshError("the mesh has non-finite vertex coordinates")
    return mesh_or_path


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
    # twice the signed projected area; triangles seen edge-on can not be hit
    area2 = (p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1]) - (p[:, 1, 1] - p[:, 0, 1]) * (
        p[:, 2, 0] - p[:, 0, 0]
    )
    # node index ranges of each triangle's bounding box, widened by the tolerance
    lo = (p.min(axis=1) - tol - np.asarray(origin)) / np.asarray(step)
    hi = (p.max(axis=1) + tol - np.asarray(origin)) / np.asarray(step)
    lo_i = np.clip(np.ceil(lo[:, 0]), 0, ni).astype(np.int64)
    hi_i = np.clip(np.floor(hi[:, 0]), -1, ni - 1).astype(np.int64)
    lo_j = np.clip(np.ceil(lo[:, 1]), 0, nj).astype(np.int64)
    hi_j = np.clip(np.floor(hi[:, 1]), -1, nj - 1).astype(np.int64)
    width = np.maximum(hi_i - lo_i + 1, 0)
    count = width * np.maximum(hi_j - lo_j + 1, 0)
    live = np.flatnonzero((count > 0) & (area2 != 0.0))
    if len(live) == 0:
        return height, face
    # orient every live triangle counter-clockwise so inside means all edge functions >= 0
    flip = area2[live] < 0
    corners = p[live].copy()
    heights = h[live].copy()
    corners[flip] = corners[flip][:, [0, 2, 1]]
    heights[flip] = heights[flip][:, [0, 2, 1]]
    # edge k runs from corner k+1 to corner k+2 (opposite corner k); its length scales tol
    edge = np.roll(corners, -2, axis=1) - np.roll(corners, -1, axis=1)
    slack = tol * np.hypot(edge[..., 0], edge[..., 1])  # (L, 3)
    ends = np.cumsum(count[live])  # flat node numbering over all live boxes
    starts = ends - count[live]
    total = int(ends[-1])
    for first in range(0, total, CHUNK_NODES):
        flat = np.arange(first, min(first + CHUNK_NODES, total), dtype=np.int64)
        k = np.searchsorted(ends, flat, side="right")  # which live triangle
        off = flat - starts[k]
        tri = live[k]
        i = lo_i[tri] + off % width[tri]
        j = lo_j[tri] + off // width[tri]
        qu = origin[0] + i * step[0]
        qv = origin[1] + j * step[1]
        c = corners[k]  # (n, 3, 2)
        e = edge[k]
        # w[:, m]: twice the area of (q, corner m+1, corner m+2), the weight of corner m
        b = np.roll(c, -1, axis=1)
        w = e[..., 0] * (qv[:, None] - b[..., 1]) - e[..., 1] * (qu[:, None] - b[..., 0])
        inside = np.all(w >= -slack[k], axis=1)
        if not inside.any():
            continue
        w = w[inside]
        hk = heights[k[inside]]
        # relative to corner 0, so a level triangle gives its height exactly
        rise = w[:, 1] * (hk[:, 1] - hk[:, 0]) + w[:, 2] * (hk[:, 2] - hk[:, 0])
        hit_h = hk[:, 0] + rise / w.sum(axis=1)
        ray = j[inside] * ni + i[inside]
        np.maximum.at(height, ray, hit_h)
        top = hit_h >= height[ray]
        face[ray[top]] = tri[inside][top]
    return height, face


def _grid_axis(lo: float, hi: float, step: float) -> tuple[float, int]:
    """First node and node count of a grid with this step, centred on [lo, hi]."""
    count = int(math.floor((hi - lo) / step + 1e-9)) + 1
    return lo + 0.5 * ((hi - lo) - (count - 1) * step), count


def _positive(value: float | None, name: str) -> float | None:
    if value is None:
        return None
    try:
        out = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be a positive number, got {value!r}") from None
    if not math.isfinite(out) or out <= 0.0:
        raise ParameterError(f"{name} must be a positive finite number, got {value!r}")
    return out


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
        height, _ = cast_grid(
            self.tri_uv,
            self.tri_h,
            (a0, c0),
            (spacing, line_spacing),
            (na, nc),
            tol=EDGE_TOL * self.scale,
        )
        return height, grid


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
    spacing = _positive(spacing, "spacing")
    line_spacing = _positive(line_spacing, "line_spacing")
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
    _, line_ids = np.unique(j, return_inverse=True)
    return np.ascontiguousarray(points), line_ids.astype(np.int64)


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
            best = (miss, spacing, height, grid)
        if miss <= N_POINTS_RTOL or (hits == 0 and spacing < 1e-9 * scanner.scale):
            break
        spacing *= (max(hits, 1) / n_points) ** (1.0 / power)
    _, spacing, height, grid = best
    return spacing, height, grid
