"""Triangulation along a range grid: the scanner's neighbours form the triangles.

A range scanner records more than points: each sample sits in a grid of rays (a
``range_grid`` PLY's rows and columns, a height grid's cells, a simulated scan's lines and
positions), and the space in front of every sample is known to be empty. So the candidate
triangles are the grid's own cells (two per 2 x 2 block of samples, split along the shorter
3-D diagonal; one where a corner is missing), and a candidate is dropped where the scanner
cannot have seen it: its normal turns more than ``max_turn`` (θ) from the line of sight (a
sheet hanging across a depth jump stands edge-on to the rays) or an edge is longer than
``edge_factor`` (k) x the local grid spacing. θ and k are the core's
``DEFAULT_GRID_TURN_DEG`` and ``DEFAULT_GRID_EDGE_FACTOR`` (85 degrees, so that no kept face
is within the curtain report's 5 degrees of the sight, and 8 spacings, so that the sheet
across a step a few spacings high is kept), chosen by ``benches/curtains.py``
(docs/benchmarks/curtains.md).

The line of sight is ``PlanarScan.sight``: the scanner's recorded ``up``, else the normal
of the scan's projection plane. The faces are counter-clockwise in the scan's plane, so LOP and
annealing can start from them and flip inside their outline.
"""

from __future__ import annotations

import time
from typing import Any

from numpy.typing import ArrayLike

from scanmesh import _core
from scanmesh._checks import Option, check_options
from scanmesh._context import QUIET, Context
from scanmesh._interrupt import interruptible
from scanmesh._progress import Progress
from scanmesh.errors import DegenerateInputError, ParameterError
from scanmesh.formats import ScanPoints
from scanmesh.scan.planar import PlanarScan, as_scan
from scanmesh.scan.projection import PlaneSpec
from scanmesh.surface import Surface

#: The grid method's options (also those of the "grid" start of LOP and annealing).
OPTIONS: tuple[Option, ...] = (
    Option(
        "max_turn",
        "float",
        _core.DEFAULT_GRID_TURN_DEG,
        "largest angle (degrees) between a kept face's normal and the line of sight",
        low=0.0,
        high=90.0,
        low_open=True,
    ),
    Option(
        "edge_factor",
        "float",
        _core.DEFAULT_GRID_EDGE_FACTOR,
        "longest kept 3-D edge, in local grid spacings (inf: no limit)",
        low=0.0,
        low_open=True,
        finite=False,
    ),
)


def is_gridded(scan: PlanarScan) -> bool:
    """True when ``scan`` came with a range grid of at least 2 x 2 cells, so that
    :func:`grid_surface` can triangulate it."""
    grid = scan.grid
    return grid is not None and grid.ndim == 2 and min(grid.shape) >= 2


def grid_surface(
    source: ArrayLike | PlanarScan | ScanPoints,
    *,
    plane: PlaneSpec = None,
    max_turn: float = _core.DEFAULT_GRID_TURN_DEG,
    edge_factor: float = _core.DEFAULT_GRID_EDGE_FACTOR,
    progress: Progress = False,
) -> Surface:
    """Triangulate a gridded scan along its grid (see the module doc).

    Parameters
    ----------
    source : PlanarScan or ScanPoints
        A scan with a range grid (``PlanarScan.grid``: read from a ``range_grid`` PLY or a
        height grid, or :func:`scanmesh.evaluate.digitizer.simulate_range_scan`).
    plane : as in :func:`scanmesh.planar_scan`
        Projection plane for a ScanPoints.
    max_turn : float
        θ, degrees in (0, 90].
    edge_factor : float
        k, > 0 (``math.inf``: no edge limit).
    progress : bool or callable
        Reports the stage "grid" (cells) at its start and end.

    Returns
    -------
    Surface
        method "grid"; ``options`` holds ``max_turn``, ``edge_factor``, the grid
        ``spacing`` (median, across the line of sight), the candidate count and how many
        were dropped by each rule (``dropped_turned``, ``dropped_long``,
        ``dropped_folded``, and ``dropped_peeled``: pinches and boundary slivers peeled so
        that LOP and annealing can start from it), and ``trimmed``, the points in no face.
        O(cells).

    Raises
    ------
    ParameterError
        A scan without a range grid, or options out of range.
    DegenerateInputError
        No candidate is kept.
    """
    scan = as_scan(source, plane=plane)
    params = check_options(
        OPTIONS, {"max_turn": max_turn, "edge_factor": edge_factor}, "grid triangulation"
    )
    return build_grid(scan, params, Context.of(progress))


def build_grid(scan: PlanarScan, params: dict[str, Any], context: Context = QUIET) -> Surface:
    """:func:`grid_surface` of ``scan`` without its option checks: ``params`` checked
    (:data:`OPTIONS`), the progress the call's (``context``), as the registry
    (``scanmesh.methods``) has them. Same result, warnings and errors otherwise."""
    if scan.grid is not None and not is_gridded(scan):
        shape = " x ".join(map(str, scan.grid.shape))
        raise DegenerateInputError(
            f"the scan's range grid is {shape} (lines x positions): the grid triangulation"
            " needs at least 2 x 2 to make a triangle; use another method"
        )
    if not is_gridded(scan):
        raise ParameterError(
            "the grid triangulation needs a scan with a range grid (a range_grid PLY, a"
            " height grid read with grid=True, or a simulated range scan)"
        )
    grid = scan.grid
    assert grid is not None
    t0 = time.perf_counter()
    with context.stage("grid", grid.size, blocking=True):
        result = interruptible(
            grid.size,
            _core.grid_triangulate,
            grid,
            scan.uv,
            scan.points,
            scan.sight,
            params["max_turn"],
            params["edge_factor"],
        )
    faces = result.faces
    if len(faces) == 0:
        raise DegenerateInputError(
            f"the grid triangulation kept none of its {result.candidates} candidate triangles"
            f" (max_turn={params['max_turn']:g}, edge_factor={params['edge_factor']:g}):"
            " the grid does not face the line of sight"
        )
    return Surface(
        vertices=scan.points,
        faces=faces,
        method="grid",
        options={
            "plane": scan.plane,
            **params,
            "spacing": result.spacing,
            "candidates": result.candidates,
            "dropped_turned": result.turned,
            "dropped_long": result.long,
            "dropped_folded": result.folded,
            "dropped_peeled": result.peeled,
            "trimmed": result.unused,
        },
        scan=scan,
        timings={**scan.timings, "triangulate": time.perf_counter() - t0},
        line_ids=scan.line_ids,
    )


__all__ = ["OPTIONS", "grid_surface", "is_gridded"]
