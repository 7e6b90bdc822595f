"""What one tile does on a worker: triangulate its region, trim at the global length,
keep the triangles it owns, estimate its noise, and optimize its pieces (LOP or
annealing) in the two passes (see :mod:`scanmesh.distributed._tiles`)."""

from __future__ import annotations

import dataclasses
import math
import os
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from scanmesh import _core
from scanmesh.distributed._grid import Bins, Grid, certified, circumcentres
from scanmesh.distributed._output import FaceBlock
from scanmesh.errors import ScanmeshError
from scanmesh.methods import TABLE
from scanmesh.scan.noise import median_edge, noise
from scanmesh.scan.planar import PlanarScan
from scanmesh.scan.projection import Frame, PlaneSpec
from scanmesh.stages.anneal import drive, planned
from scanmesh.stages.options import JUMP_FACTOR


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
    if not TABLE[method].anneals:  # LOP
        done, _ = _core.lop(
            pts,
            puv,
            local,
            params["criterion"],
            p=params["p"],
            sliver_guard=params["sliver_guard"],
            tie_tolerance=params["tie_tolerance"],
        )
    else:
        # time_limit bounds each tile's pass (the tiles of a pass run side by side)
        planned_params = planned(params, len(used), local)
        native = {k: v for k, v in planned_params.items() if k != "time_limit"}
        runner = _core.Annealer(pts, puv, local, _core.AnnealParams(seed=seed, **native))
        drive(runner, 0, False, params.get("time_limit"))
        done = runner.finish().faces
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
    lowest-index corner it owns. ``after``: the gate of
    :func:`scanmesh.distributed._tiles._gated`."""
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


def _tile_seed(seed: int, phase: int, tile: int) -> int:
    return int(np.random.SeedSequence([seed, phase, tile]).generate_state(1, np.uint64)[0])
