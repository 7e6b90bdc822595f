"""A reconstructed mesh against a known true surface (a CAD truth): height error, normal
error (:func:`normal_error`) and domain error (:func:`domain_error`); and, for real scans
without a truth, the holdout error (:func:`holdout_error`: withheld scan points against the
mesh of the others, along the projection normal).

The height measure: points sampled uniformly at random on the reconstructed mesh's area
(weighted by triangle area, so a large wrong triangle counts as much as it covers), and for
each sample its **closest-point distance** to the true surface (unsigned, in the model's
units): the distance ``trimesh.proximity.closest_point`` returns. It is not the distance
along the projection normal: where a mesh bridges a step or a hole, the closest-point
distance is the distance to the wall, never more.

The distances are exact (checked against brute force over every triangle) and computed here
rather than by trimesh, whose nearest-vertex search box makes 100,000 queries on a CAD part
with large faces take half a minute: the truth's triangles are binned into a uniform grid,
each query first looks in its own cell and then, with the distance found as a bound, in the
few cells that bound reaches; a best-first search in trimesh's r-tree settles the rest
(points far from the surface).
"""

from __future__ import annotations

import math
import os
from typing import Any

import numpy as np

from scanmesh._checks import as_faces, as_points
from scanmesh._interrupt import import_interruptibly
from scanmesh.errors import InvalidMeshError, ParameterError
from scanmesh.evaluate.digitizer import cast_grid
from scanmesh.formats.mesh import load_mesh
from scanmesh.scan.locate import expand
from scanmesh.scan.projection import project

#: What :func:`height_error` measures, for reports.
MEASURE = "closest-point distance to the true surface at random points on the mesh's area"

#: What :func:`normal_error` measures, for reports.
NORMAL_MEASURE = (
    "unoriented angle between the mesh's face normal and the normal of the closest true"
    " triangle, at random points on the mesh's area"
)

#: Most (cell, triangle box) pairs the grid expands while binning; cells grow until it fits.
MAX_BINNED: int = 1 << 22

#: Grid cells: CELL_FACTOR times a typical triangle's box (its longest side), within
#: CELLS_PER_DIAGONAL cells per diagonal of the truth's box.
CELL_FACTOR: float = 2.0
CELLS_PER_DIAGONAL = (100, 1000)

#: A query whose bound reaches more cells than this goes to the r-tree instead.
MAX_CELLS_PER_QUERY: int = 64

#: Triangle boxes fetched first per r-tree query (then 4 times as many, while needed).
TREE_FIRST_K: int = 16

#: Offset of the grid from the truth's box, in cells per axis, so that flat CAD faces do not
#: lie on cell walls.
GRID_SHIFT = (0.3819660113, 0.2763932023, 0.1458980338)


def point_triangle_distance(triangles: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Distance from each point to the matching triangle (pairwise, not all against all).

    Parameters
    ----------
    triangles : (n, 3, 3) float
        Triangle corners.
    points : (n, 3) float
        One point per triangle.

    Returns
    -------
    (n,) float64
        Euclidean distance to the closest point of the closed triangle; a degenerate
        triangle counts as its edges.

    Notes
    -----
    Ericson's region test (*Real-Time Collision Detection*, 5.1.5) on coordinate columns:
    the closest point is ``a + v (b - a) + w (c - a)`` with (v, w) chosen by the Voronoi
    region of the triangle that holds the point.
    """
    n = len(points)
    t = np.ascontiguousarray(np.asarray(triangles, dtype=np.float64).reshape(n, 9).T)
    p = np.ascontiguousarray(np.asarray(points, dtype=np.float64).T)
    a = t[0:3]
    ab, ac, ap = t[3:6] - a, t[6:9] - a, p - a  # (3, n) each
    bp, cp = ap - ab, ap - ac

    def dot(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        return x[0] * y[0] + x[1] * y[1] + x[2] * y[2]

    d1, d2 = dot(ab, ap), dot(ac, ap)
    d3, d4 = dot(ab, bp), dot(ac, bp)
    d5, d6 = dot(ab, cp), dot(ac, cp)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    with np.errstate(divide="ignore", invalid="ignore"):
        denom = va + vb + vc
        e_bc = (d4 - d3) + (d5 - d6)
        conditions = [
            (d1 <= 0) & (d2 <= 0),  # corner a
            (d3 >= 0) & (d4 <= d3),  # corner b
            (d6 >= 0) & (d5 <= d6),  # corner c
            (vc <= 0) & (d1 >= 0) & (d3 <= 0),  # edge ab
            (vb <= 0) & (d2 >= 0) & (d6 <= 0),  # edge ac
            (va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0),  # edge bc
        ]
        v = np.select(
            conditions, [0.0, 1.0, 0.0, d1 / (d1 - d3), 0.0, 1 - (d4 - d3) / e_bc], vb / denom
        )
        w = np.select(
            conditions, [0.0, 0.0, 1.0, 0.0, d2 / (d2 - d6), (d4 - d3) / e_bc], vc / denom
        )
    off = ap - v * ab - w * ac  # from the closest point to the point
    dist = np.sqrt(dot(off, off))
    bad = np.flatnonzero(~np.isfinite(dist))
    if len(bad):  # degenerate (collinear) triangles: the nearest of the three edges
        dist[bad] = _edges_distance(np.asarray(triangles)[bad], np.asarray(points)[bad])
    return dist


def _edges_distance(triangles: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(n,) distance from each point to the nearest edge of its triangle (n, 3, 3)."""
    best = np.full(len(points), np.inf)
    for i, j in ((0, 1), (1, 2), (2, 0)):
        start, edge = triangles[:, i], triangles[:, j] - triangles[:, i]
        ee = np.einsum("ij,ij->i", edge, edge)
        f = np.einsum("ij,ij->i", points - start, edge) / np.where(ee > 0, ee, 1.0)
        off = points - start - np.clip(f, 0.0, 1.0)[:, None] * edge
        best = np.minimum(best, np.einsum("ij,ij->i", off, off))
    return np.sqrt(best)


def _box_cells(lo: np.ndarray, span: np.ndarray, owner: np.ndarray, off: np.ndarray) -> np.ndarray:
    """(n, 3) int64 cell indices: item ``off`` of the cell box of ``owner`` (x fastest)."""
    s = span[owner]
    rest = off // s[:, 0]
    return lo[owner] + np.column_stack((off % s[:, 0], rest % s[:, 1], rest // s[:, 1]))


def _reduce_min(
    best: np.ndarray,
    rows: np.ndarray,
    values: np.ndarray,
    arg: np.ndarray | None = None,
    items: np.ndarray | None = None,
) -> None:
    """``best[r] = min(best[r], values of row r)``, for ``rows`` sorted ascending.

    With ``arg`` and ``items``: where a row's minimum improves ``best``, ``arg[r]`` becomes
    the ``items`` entry that attains it (the first one on ties).
    """
    if len(rows) == 0:
        return
    first = np.flatnonzero(np.r_[True, rows[1:] != rows[:-1]])
    owners = rows[first]
    low = np.minimum.reduceat(values, first)
    if arg is not None and items is not None:
        group = np.cumsum(np.r_[False, rows[1:] != rows[:-1]])  # group of each entry
        attains = np.flatnonzero(values == low[group])
        _, pick = np.unique(group[attains], return_index=True)
        better = low < best[owners]
        arg[owners[better]] = items[attains[pick]][better]
    best[owners] = np.minimum(best[owners], low)


class TrueSurface:
    """A true surface prepared for many closest-point queries (build once, query often).

    Parameters
    ----------
    mesh : trimesh.Trimesh or path
        The true surface (any mesh file trimesh reads).
    """

    def __init__(self, mesh: Any) -> None:
        self.mesh = load_mesh(mesh)
        #: (F, 3, 3) float64 triangle corners
        self.triangles = np.ascontiguousarray(self.mesh.triangles, dtype=np.float64)
        lo = self.triangles.min(axis=1)  # (F, 3) triangle boxes
        hi = self.triangles.max(axis=1)
        diag = float(np.linalg.norm(hi.max(axis=0) - lo.min(axis=0))) or 1.0
        typical = float(np.median((hi - lo).max(axis=1)))
        h = min(
            max(CELL_FACTOR * typical, diag / CELLS_PER_DIAGONAL[1]), diag / CELLS_PER_DIAGONAL[0]
        )
        while True:
            origin = lo.min(axis=0) - np.asarray(GRID_SHIFT) * h
            cell_lo = np.floor((lo - origin) / h).astype(np.int64)
            span = np.floor((hi - origin) / h).astype(np.int64) - cell_lo + 1  # (F, 3)
            if span.prod(axis=1).sum() <= MAX_BINNED:
                break
            h *= 1.25
        #: grid cell size and the corner of cell (0, 0, 0)
        self.cell, self.origin = h, origin
        self.shape = cell_lo.max(axis=0) + span.max(axis=0) + 1
        keys, tris = [], []
        for owner, off in expand(span.prod(axis=1)):
            cells = _box_cells(cell_lo, span, owner, off)
            # keep a triangle in a cell only if it comes within the cell's circumsphere
            centre = origin + (cells + 0.5) * h
            near = point_triangle_distance(self.triangles[owner], centre) <= 0.8661 * h
            keys.append(self._key(cells[near]))
            tris.append(owner[near])
        key = np.concatenate(keys)
        order = np.argsort(key, kind="stable")
        key = key[order]
        #: triangle ids grouped by cell; the cells' keys ascending with their ranges
        self.tris = np.concatenate(tris)[order]
        first = np.flatnonzero(np.r_[True, key[1:] != key[:-1]]) if len(key) else key
        self.keys = key[first]
        self.starts = first
        self.stops = np.r_[first[1:], len(key)].astype(np.int64)

    def _key(self, cells: np.ndarray) -> np.ndarray:
        return (cells[:, 0] * self.shape[1] + cells[:, 1]) * self.shape[2] + cells[:, 2]

    def _search_cells(
        self,
        points: np.ndarray,
        bound: np.ndarray,
        best: np.ndarray,
        arg: np.ndarray | None = None,
    ) -> None:
        """Lower ``best`` by the triangles binned in the cells that ``point +- bound`` meets
        (and set ``arg`` to the triangle that lowered it, when given)."""
        lo = np.floor((points - bound[:, None] - self.origin) / self.cell).astype(np.int64)
        hi = np.floor((points + bound[:, None] - self.origin) / self.cell).astype(np.int64)
        lo = np.clip(lo, 0, self.shape - 1)
        hi = np.clip(hi, -1, self.shape - 1)
        span = np.maximum(hi - lo + 1, 0)
        for rows, off in expand(span.prod(axis=1)):
            key = self._key(_box_cells(lo, span, rows, off))
            slot = np.clip(np.searchsorted(self.keys, key), 0, max(len(self.keys) - 1, 0))
            hit = (self.keys[slot] == key) if len(self.keys) else np.zeros(len(key), bool)
            count = np.where(hit, self.stops[slot] - self.starts[slot], 0)
            for k, item in expand(count):
                tri = self.tris[self.starts[slot[k]] + item]
                who = rows[k]
                dist = point_triangle_distance(self.triangles[tri], points[who])
                _reduce_min(best, who, dist, arg, tri)

    def _search_tree(
        self, points: np.ndarray, best: np.ndarray, arg: np.ndarray | None = None
    ) -> None:
        """Lower ``best`` to the exact distance, best-first through the r-tree.

        The triangles whose boxes are nearest come first; once the k-th box is farther than
        the closest triangle found, no other triangle can be closer.
        """
        tree = self.mesh.triangles_tree
        todo = np.arange(len(points))
        k = TREE_FIRST_K
        while len(todo):
            q = points[todo]
            ids, counts, kth = tree.nearest_v(q, q, num_results=k, return_max_dists=True)
            counts = counts.astype(np.int64)
            starts = np.cumsum(counts) - counts
            ids = ids.astype(np.int64)
            sub = best[todo]
            sub_arg = arg[todo] if arg is not None else None
            for rows, off in expand(counts):
                found = ids[starts[rows] + off]
                dist = point_triangle_distance(self.triangles[found], q[rows])
                _reduce_min(sub, rows, dist, sub_arg, found)
            best[todo] = sub
            if arg is not None:
                arg[todo] = sub_arg
            # not settled: k boxes returned (there may be more) and the k-th is not farther
            open_ = (counts >= k) & (np.asarray(kth) < sub) & (k < len(self.triangles))
            todo = todo[open_]
            k *= 4

    def distance(self, points: Any) -> np.ndarray:
        """Unsigned closest-point distance from each point to the true surface.

        Parameters
        ----------
        points : (N, 3) float
            Query points.

        Returns
        -------
        (N,) float64
            Exact distances (the values of ``trimesh.proximity.closest_point``, which can
            be a little larger where its candidate search misses the closest triangle).
        """
        return self._query(points, track=False)[0]

    def closest(self, points: Any) -> tuple[np.ndarray, np.ndarray]:
        """Closest-point distance and the true triangle that attains it, for each point.

        Parameters
        ----------
        points : (N, 3) float
            Query points.

        Returns
        -------
        distance : (N,) float64
            As :meth:`distance`.
        triangle : (N,) int64
            Index into ``mesh.faces`` of a closest triangle (where several are equally
            close, e.g. at a shared edge or a crease, one of them).
        """
        distance, triangle = self._query(points, track=True)
        assert triangle is not None
        return distance, triangle

    def _query(self, points: Any, track: bool) -> tuple[np.ndarray, np.ndarray | None]:
        pts = np.ascontiguousarray(points, dtype=np.float64)
        if pts.ndim != 2 or pts.shape[1] != 3:
            raise ParameterError(f"points must have shape (N, 3), got {pts.shape}")
        best = np.full(len(pts), np.inf)
        arg = np.full(len(pts), -1, dtype=np.int64) if track else None
        # pass 1: the point's own cell; a distance within the point's margin to the cell's
        # walls is final (a closer triangle would come into the cell)
        self._search_cells(pts, np.zeros(len(pts)), best, arg)
        frac = (pts - self.origin) / self.cell
        frac -= np.floor(frac)
        margin = np.minimum(frac, 1.0 - frac).min(axis=1) * self.cell
        # pass 2: every cell within the distance found, or within one cell of an empty one;
        # exact where the distance found is within that reach, as any closer triangle comes
        # within it and so is binned in one of those cells
        reach = np.where(np.isfinite(best), best, self.cell) * (1 + 1e-9)
        cells = (np.ceil(reach / self.cell) * 2 + 2) ** 3  # cells the box may meet
        near = np.flatnonzero((cells <= MAX_CELLS_PER_QUERY) & ~(best <= margin))
        if len(near):
            sub, sub_arg = best[near], (arg[near] if arg is not None else None)
            self._search_cells(pts[near], reach[near], sub, sub_arg)
            best[near] = sub
            if arg is not None:
                arg[near] = sub_arg
        settled = best <= margin
        settled[near] = best[near] <= reach[near]
        # pass 3: far from the surface: the r-tree
        far = np.flatnonzero(~settled)
        if len(far):
            sub, sub_arg = best[far], (arg[far] if arg is not None else None)
            self._search_tree(pts[far], sub, sub_arg)
            best[far] = sub
            if arg is not None:
                arg[far] = sub_arg
        return best, arg


def _as_trimesh(mesh: Any, name: str):
    """A ``trimesh.Trimesh`` from a Surface, a Trimesh, a (vertices, faces) pair or a path."""
    trimesh = import_interruptibly("trimesh")

    if isinstance(mesh, (trimesh.Trimesh, str, os.PathLike)):
        return load_mesh(mesh)
    if isinstance(mesh, tuple) and len(mesh) == 2:
        vertices, faces = mesh
    elif hasattr(mesh, "vertices") and hasattr(mesh, "faces"):
        vertices, faces = mesh.vertices, mesh.faces
    else:
        raise ParameterError(
            f"{name} must be a Surface, a trimesh.Trimesh, a (vertices, faces) pair or a mesh"
            f" file, got {type(mesh).__name__}"
        )
    v = as_points(vertices, f"{name} vertices")
    f = as_faces(faces, len(v))
    if len(f) == 0:
        raise InvalidMeshError(f"{name} has no triangles")
    return trimesh.Trimesh(vertices=v, faces=f, process=False)


def _canonical(mesh: Any):
    """The same triangles in one order that depends on the face set only: each face's
    vertex indices sorted, then the faces sorted, so that the random samples (drawn face by
    face along the cumulative area, from each face's first corner) are the same for the same
    faces in any order and with their corners in any order. Orientation is dropped: both
    measures on the samples are unsigned."""
    trimesh = import_interruptibly("trimesh")

    faces = np.sort(np.asarray(mesh.faces, dtype=np.int64), axis=1)
    faces = faces[np.lexsort((faces[:, 2], faces[:, 1], faces[:, 0]))]
    return trimesh.Trimesh(vertices=mesh.vertices, faces=faces, process=False)


def height_error(
    surface: Any, truth_mesh: Any, n_samples: int = 100_000, seed: int = 0
) -> dict[str, Any]:
    """How far a reconstructed mesh lies from the true surface.

    Parameters
    ----------
    surface : Surface, trimesh.Trimesh, (vertices, faces) or path
        The reconstructed mesh.
    truth_mesh : TrueSurface, trimesh.Trimesh or path
        The true surface (a CAD model the scan was simulated from). Pass a
        :class:`TrueSurface` to measure several meshes against one truth without rebuilding
        its search grid.
    n_samples : int
        Random points sampled on ``surface``'s area (default 100,000).
    seed : int
        Seed of the sampling: the same seed gives the same figures, for the same faces in any order.

    Returns
    -------
    dict
        ``h_rms``, ``h_mean``, ``h_max``: root mean square, mean and largest closest-point
        distance of the samples to the truth (model units); ``n_samples``; ``measure``
        (:data:`MEASURE`).
    """
    trimesh = import_interruptibly("trimesh")

    if isinstance(n_samples, bool) or not isinstance(n_samples, (int, np.integer)):
        raise ParameterError(f"n_samples must be a whole number, got {n_samples!r}")
    if n_samples < 1:
        raise ParameterError(f"n_samples must be at least 1, got {n_samples}")
    mesh = _canonical(_as_trimesh(surface, "the mesh"))
    truth = truth_mesh if isinstance(truth_mesh, TrueSurface) else TrueSurface(truth_mesh)
    area = float(mesh.area)
    if not math.isfinite(area) or area <= 0:
        raise InvalidMeshError("the mesh has no area to sample")
    samples, _ = trimesh.sample.sample_surface(mesh, int(n_samples), seed=seed)
    dist = truth.distance(samples)
    return {
        "h_rms": float(np.sqrt(np.mean(dist * dist))),
        "h_mean": float(np.mean(dist)),
        "h_max": float(np.max(dist)),
        "n_samples": int(len(dist)),
        "measure": MEASURE,
    }


def normal_error(
    surface: Any, truth_mesh: Any, n_samples: int = 100_000, seed: int = 0
) -> dict[str, Any]:
    """How far a reconstructed mesh's normals turn from the true surface's normals.

    At each of ``n_samples`` random points on the mesh's area (the same points as
    :func:`height_error` with the same seed) the angle between the normal of the mesh face
    holding the point and the normal of the closest true triangle. Orientation is ignored
    (the angle is in 0..90 degrees), so a mesh wound either way scores the same.

    Parameters
    ----------
    surface, truth_mesh, n_samples, seed
        As :func:`height_error`.

    Returns
    -------
    dict
        ``n_mean_deg``, ``n_rms_deg``, ``n_median_deg``, ``n_max_deg``: statistics of the
        angle in degrees; ``n_samples``; ``measure`` (:data:`NORMAL_MEASURE`).
    """
    trimesh = import_interruptibly("trimesh")

    if isinstance(n_samples, bool) or not isinstance(n_samples, (int, np.integer)):
        raise ParameterError(f"n_samples must be a whole number, got {n_samples!r}")
    if n_samples < 1:
        raise ParameterError(f"n_samples must be at least 1, got {n_samples}")
    mesh = _canonical(_as_trimesh(surface, "the mesh"))
    truth = truth_mesh if isinstance(truth_mesh, TrueSurface) else TrueSurface(truth_mesh)
    area = float(mesh.area)
    if not math.isfinite(area) or area <= 0:
        raise InvalidMeshError("the mesh has no area to sample")
    samples, face = trimesh.sample.sample_surface(mesh, int(n_samples), seed=seed)
    _, closest = truth.closest(samples)
    tri = mesh.triangles[face]
    tt = truth.triangles[closest]
    a = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    b = np.cross(tt[:, 1] - tt[:, 0], tt[:, 2] - tt[:, 0])
    # unoriented angle, atan2 form (stable near 0 and 90 degrees)
    angle = np.degrees(
        np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.abs(np.einsum("ij,ij->i", a, b)))
    )
    return {
        "n_mean_deg": float(angle.mean()),
        "n_rms_deg": float(np.sqrt(np.mean(angle * angle))),
        "n_median_deg": float(np.median(angle)),
        "n_max_deg": float(angle.max()),
        "n_samples": int(len(angle)),
        "measure": NORMAL_MEASURE,
    }


#: What :func:`domain_error` measures, for reports.
DOMAIN_MEASURE = (
    "area the mesh covers outside the true part's shadow (air) and the part's shadow area"
    " the mesh leaves uncovered (missed), seen along the projection normal"
)

#: Rays :func:`domain_error` casts by default (its grid step follows from it).
DOMAIN_RAYS: int = 4_000_000


def domain_error(
    surface: Any, truth_mesh: Any, plane: Any = None, n_rays: int = DOMAIN_RAYS
) -> dict[str, Any]:
    """Where a mesh's planar domain and the true part disagree, seen along the projection.

    A planar method decides which part of the plane the mesh covers (Delaunay's trimming,
    the strips' windows). Two ways to get it wrong: covering **air**, where the part casts no
    shadow (triangles bridging a concave outline, a bore or a gap), and **missing** part of
    the shadow (a mesh through the samples stops at the outermost ones, so a band along
    every outline up to one spacing wide is always missed; trimming opens more). Both are
    counted on one grid of parallel rays along the projection normal: a ray counts for the
    mesh if it hits a mesh triangle, for the truth if it hits any true triangle. Each
    figure is good to about one ray spacing times the length of the outlines involved.

    Parameters
    ----------
    surface : Surface, trimesh.Trimesh, (vertices, faces) or path
        The reconstructed mesh.
    truth_mesh : TrueSurface, trimesh.Trimesh or path
        The true part.
    plane : None, "x", "y", "z" or (3,) float
        Projection plane (as :func:`scanmesh.scan.projection.project`); None takes the
        Surface's own plane (``Surface.frame``), so it is required for other meshes.
    n_rays : int
        Rays cast (default :data:`DOMAIN_RAYS`), on a square grid over the box of both
        meshes' shadows. O(n_rays + faces).

    Returns
    -------
    dict
        ``air`` and ``missed`` (areas, model units squared), ``air_share`` and
        ``missed_share`` (as fractions of the truth's shadow area), ``truth_area`` and
        ``mesh_area`` (shadow areas), ``step`` (ray spacing), ``measure``
        (:data:`DOMAIN_MEASURE`).
    """
    if isinstance(n_rays, bool) or not isinstance(n_rays, (int, np.integer)):
        raise ParameterError(f"n_rays must be a whole number, got {n_rays!r}")
    if n_rays < 1:
        raise ParameterError(f"n_rays must be at least 1, got {n_rays}")
    frame = getattr(surface, "frame", None) if plane is None else None
    if plane is None and frame is None:
        raise ParameterError("plane is required unless the mesh is a Surface with a frame")
    mesh = _as_trimesh(surface, "the mesh")
    true_mesh = truth_mesh.mesh if isinstance(truth_mesh, TrueSurface) else None
    if true_mesh is None:
        true_mesh = load_mesh(truth_mesh)
    if frame is None:
        _, frame = project(mesh.vertices, plane)
    axes = np.column_stack([frame.u, frame.v])  # (3, 2): 3-D point -> planar coordinates

    def shadow_triangles(m: Any) -> np.ndarray:
        return np.asarray(m.triangles, dtype=np.float64) @ axes  # (F, 3, 2)

    ours, theirs = shadow_triangles(mesh), shadow_triangles(true_mesh)
    lo = np.minimum(ours.reshape(-1, 2).min(axis=0), theirs.reshape(-1, 2).min(axis=0))
    hi = np.maximum(ours.reshape(-1, 2).max(axis=0), theirs.reshape(-1, 2).max(axis=0))
    span = hi - lo
    step = math.sqrt(max(float(span[0] * span[1]), float(span.max()) ** 2 / n_rays) / n_rays)
    if not math.isfinite(step) or step <= 0:
        raise InvalidMeshError("the meshes cast no shadow on the plane")
    # nodes at cell centres, so a grid edge never runs along a box side
    shape = (int(span[0] / step) + 1, int(span[1] / step) + 1)
    origin = (float(lo[0]) + step / 2, float(lo[1]) + step / 2)

    def covered(tri: np.ndarray) -> np.ndarray:
        _, face = cast_grid(tri, np.zeros(tri.shape[:2]), origin, (step, step), shape)
        return face >= 0

    in_mesh, in_truth = covered(ours), covered(theirs)
    cell = step * step
    truth_area = float(in_truth.sum()) * cell
    if truth_area <= 0:
        raise InvalidMeshError("the true part casts no shadow on the plane")
    air = float((in_mesh & ~in_truth).sum()) * cell
    missed = float((in_truth & ~in_mesh).sum()) * cell
    return {
        "air": air,
        "missed": missed,
        "air_share": air / truth_area,
        "missed_share": missed / truth_area,
        "truth_area": truth_area,
        "mesh_area": float(in_mesh.sum()) * cell,
        "step": step,
        "measure": DOMAIN_MEASURE,
    }
