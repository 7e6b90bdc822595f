"""Delaunay, LOP and annealing on a Dask cluster: the plane cut into tiles with an overlap band.

The scan stays in its parts (files of consecutive scan lines, :class:`Part`); no process
ever holds all of it. What the client holds is small: bounds, a seeded sample of at most
``SAMPLE_POINTS`` points (for the plane), per-tile counts, and the counts of the exact
median spacing search (:mod:`scanmesh.distributed._median`, as the strips' median step).

Rules, in order:

- **Plane.** ``plane=`` as given (an axis name or a normal; "best-fit" and None are
  resolved on the sample, see below). None: :func:`scanmesh.scan.plane_choice.choose_plane` on a
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
points in 4 tiles, tac_1 3 % above (docs/benchmarks/large-scans.md).
"""

from __future__ import annotations

import math
import operator
import shutil
import tempfile
import uuid
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from scanmesh import _core
from scanmesh._context import seed_of
from scanmesh.distributed._grid import Grid, _bin_part, project_with_box
from scanmesh.distributed._median import exact_median
from scanmesh.distributed._source import Part, load_part
from scanmesh.distributed._tile import (
    _delaunay_block,
    _nearest_only,
    _noise,
    _optimize_first,
    _optimize_second,
    _tile_seed,
    _triangulate,
    _trim,
)
from scanmesh.errors import ParameterError, ScanmeshError
from scanmesh.methods import TABLE, TILE_INITIALS, TILE_METHODS, Tiles
from scanmesh.scan.noise import tie_tolerance
from scanmesh.scan.plane_choice import choose_plane
from scanmesh.scan.projection import Frame, PlaneSpec, plane_args
from scanmesh.scan.spacing import nearest_spacing
from scanmesh.stages.anneal import ANNEAL_DEFAULTS
from scanmesh.stages.options import MAX_EDGE_FACTOR, MAX_EDGE_OPTION, SEED_OPTION

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

#: What the median spacing search reads of a tile: its own points' sorted nearest-neighbour
#: distances (:func:`scanmesh.distributed._median.exact_median`'s ``values``).
NEAREST = operator.attrgetter("nearest")

#: Tiles in flight per worker thread: tile t's first task waits for tile t - k's last
#: (k this times the cluster's threads), so a worker holds the data of a few tiles whatever
#: the scan's size; pass 1's meshes go to disk, read back by pass 2's tiles.
TILES_PER_THREAD: int = 2

# ---------------------------------------------------------------------------------------
# Geometry of the tiling


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


def _part_plane_survey(part: Part, corners: np.ndarray, plane: tuple) -> dict[str, Any]:
    """A part's planar bounds and the median spacing of its first SPACING_SAMPLE points."""
    points, _ = load_part(part)
    uv = project_with_box(points, corners, *plane)
    head = uv[:SPACING_SAMPLE]
    try:
        faces, _ = _core.delaunay(np.ascontiguousarray(head))
        spacing = nearest_spacing(head, faces)
    except (ScanmeshError, ValueError):
        spacing = math.nan
    return {
        "box": (uv[:, 0].min(), uv[:, 0].max(), uv[:, 1].min(), uv[:, 1].max()),
        "spacing": spacing,
    }


# ---------------------------------------------------------------------------------------
# Tiles (run on workers)


# ---------------------------------------------------------------------------------------
# LOP and annealing of pieces


# ---------------------------------------------------------------------------------------
# The driver (runs on the client)


def check_tile_options(
    method: str, options: dict[str, Any]
) -> tuple[dict[str, Any], float | None, int]:
    """The method's options checked by its table entry; returns (params, max_edge, seed).
    ``initial`` must be "delaunay" or "auto" (tiles start from the tiled Delaunay
    triangulation)."""
    if method not in TILE_METHODS:
        raise ParameterError(f"method {method!r} does not run in tiles; use one of {TILE_METHODS}")
    rest = dict(options)
    shared = {k: rest.pop(k) for k in ("max_edge", "seed", "lines") if k in rest}
    if "lines" in shared:
        raise ParameterError("lines= comes from the parts' files in a distributed run")
    params = TABLE[method].check(rest, shared)
    if params.pop("initial", TILE_INITIALS[0]) not in TILE_INITIALS:
        raise ParameterError(
            f"method {method!r} in tiles starts from initial='delaunay' only (got"
            f" {options.get('initial')!r})"
        )
    max_edge = shared.get("max_edge")
    given = shared.get("seed")
    seed = seed_of(None if given is None else SEED_OPTION.check(given))
    if TABLE[method].anneals and params.get("chains", 0) == 0:
        params["chains"] = 1  # automatic chains follow each piece's size, not the scan's
    return params, (None if max_edge is None else MAX_EDGE_OPTION.check(max_edge)), seed


def _resolve_plane(plane: PlaneSpec, sample: np.ndarray) -> tuple[str | None, np.ndarray | None]:
    """The plane as an axis name or a normal (never least squares over the whole scan)."""
    if plane is None:
        plane = choose_plane(sample).spec
    name, normal = plane_args(plane)
    if name == "best-fit":
        _, frame = _core.project(sample, "best-fit", None)
        return None, np.asarray(frame[3], dtype=np.float64)
    return name, normal


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
        "delaunay" or "auto"), plus the shared keywords ``max_edge`` and ``seed``.
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
        import distributed  # the optional dask extra: absent on a core install

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
        limit = MAX_EDGE_FACTOR * exact_median(client, nearest, sum(counts), NEAREST)
        del nearest
    else:
        limit = max_edge
    info: dict[str, Any] = {"tiles": grid.count, "max_edge": limit}
    entry = TABLE[method]
    if entry.tiles is Tiles.BUILT:
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
    if entry.anneals and params.get("tie_tolerance") is None:
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
    if entry.anneals:
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
