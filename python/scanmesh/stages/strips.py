"""Strip reconstruction: a Fuchs-matrix path between each two consecutive scan lines.

Between consecutive lines a_0..a_{n-1} and b_0..b_{m-1}, every strip triangulation is a
monotone path through the Fuchs matrix; the shortest-path method takes the cheapest path
under a weight, the look-ahead method (Friedhoff's alpha-look-ahead) a greedy one. Strips
join only overlapping segments of neighbouring lines, so holes stay open; lines are also
cut at depth jumps (walls, steps, bores) and triangles bridging a jump dropped, so no
curtain hangs across one; where lines cross in the plane the overlapping triangles are
dropped. Together they form one manifold mesh over the caller's points (see
``scanmesh_core::strips``).
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from scanmesh import _core
from scanmesh._checks import Option, check_options
from scanmesh._context import QUIET, Context
from scanmesh._interrupt import interruptible
from scanmesh._progress import Progress
from scanmesh.errors import (
    CoincidentPointsWarning,
    CrossingLinesWarning,
    DegenerateInputError,
    ParameterError,
    UnusedPointsWarning,
)
from scanmesh.formats import count_lines
from scanmesh.scan.lines import GAP_FACTOR_OPTION
from scanmesh.scan.planar import PlanarScan, as_scan
from scanmesh.scan.projection import PlaneSpec
from scanmesh.stages.options import JUMP_FACTOR
from scanmesh.surface import Surface

#: The path criteria, in the order the core takes their coefficients. Lengths are measured
#: in median point steps and areas in squared median steps, so that mixtures are scale-free:
#:
#: - "length": 3-D length of each edge a_i-b_j of the strip (per node);
#: - "area": 3-D area of each triangle (Fuchs, Kedem and Uselton);
#: - "angle": pi/3 minus the smallest 3-D angle of each triangle (radians);
#: - "dihedral": angle between the normals of consecutive triangles (radians).
CRITERIA: tuple[str, ...] = ("length", "area", "angle", "dihedral")

#: A weight: one criterion by name, or a mapping of criteria to non-negative coefficients.
WeightSpec = str | Mapping[str, float]

#: Default weight: of the criteria measured on fran_cut and the rod, angle + 0.3 x dihedral
#: keeps the largest smallest angle at nearly dihedral's low tac_1, where dihedral alone
#: lets the smallest angle fall (figures: docs/benchmarks/speed.md, "Quality of each weight").
DEFAULT_WEIGHT: dict[str, float] = {"angle": 1.0, "dihedral": 0.3}

#: Default look-ahead depth alpha (steps).
DEFAULT_ALPHA: int = 3

#: Shortest-path solvers: "banded" (DP in a widening band, near-linear), "dp" (the whole
#: matrix, O(nm)) and "dijkstra" (binary heap, as the seed paper, O(nm log nm)).
SOLVERS: tuple[str, ...] = ("banded", "dp", "dijkstra")


#: Rows of the planar coordinates whose rank :func:`_spans_plane` tries first.
RANK_SAMPLE: int = 65_536


def _spans_plane(uv: np.ndarray) -> bool:
    """True when the (N, 2) points are not all collinear (numerical rank 2).

    An SVD of all N rows takes seconds at 10M points, so an evenly strided sample is tried
    first: rows added to a matrix never lower its smallest singular value, so a sample of
    rank 2 means the whole has rank 2 (up to matrix_rank's size-dependent tolerance). Only
    a sample of rank < 2 (collinear input, the case that raises) pays for the full SVD.
    """
    if len(uv) > RANK_SAMPLE and _rank(uv[:: len(uv) // RANK_SAMPLE]) == 2:
        return True
    return _rank(uv) == 2


def _rank(uv: np.ndarray) -> int:
    """Numerical rank of the centred rows, scaled first: near 1e308 the mean and the SVD
    would overflow (LinAlgError, or a false rank)."""
    big = float(np.abs(uv).max()) if uv.size else 0.0
    scaled = uv / big if big > 0 else uv
    return int(np.linalg.matrix_rank(scaled - scaled.mean(axis=0)))


#: Weight coefficients are numbers >= 0 (one of them positive).
_COEFFICIENT = Option("weight", "float", 0.0, "a criterion's coefficient", low=0.0)


def weight_coefficients(weight: WeightSpec) -> tuple[float, float, float, float]:
    """The (length, area, angle, dihedral) coefficients of a weight spec."""
    if isinstance(weight, str):
        if weight not in CRITERIA:
            raise ParameterError(f"weight must be one of {CRITERIA} or a mapping, got {weight!r}")
        spec: Mapping[str, float] = {weight: 1.0}
    elif isinstance(weight, Mapping):
        spec = weight
        unknown = sorted(set(spec) - set(CRITERIA), key=repr)
        if unknown:
            raise ParameterError(f"unknown weight criteria {unknown}; known: {CRITERIA}")
    else:
        raise ParameterError(f"weight must be a criterion name or a mapping, got {weight!r}")
    coefficients = tuple(
        _COEFFICIENT.check(spec[name], f"weight[{name!r}]") if name in spec else 0.0
        for name in CRITERIA
    )
    if not any(coefficients):
        raise ParameterError(f"weight needs one positive coefficient, got {dict(spec)}")
    return coefficients  # type: ignore[return-value]


def _weight(weight: WeightSpec) -> dict[str, float]:
    return dict(zip(CRITERIA, weight_coefficients(weight), strict=True))


#: Largest initial band of the banded solver (it widens as needed; wider is the whole matrix).
MAX_BAND: int = 2**31 - 1

WEIGHT_OPTION = Option(
    "weight",
    "any",
    _weight(DEFAULT_WEIGHT),
    "a criterion of CRITERIA or a mapping of them to coefficients (angle + 0.3 dihedral)",
    convert=_weight,
)
CHECK_OPTION = Option(
    "check",
    "bool",
    True,
    "validate the mesh in the plane and drop what overlaps (False skips it at large sizes)",
)
JUMP_OPTION = Option(
    "jump_factor",
    "float",
    JUMP_FACTOR,
    "cut lines and drop triangles at depth jumps of this many local spacings (inf: never)",
    low=0.0,
    low_open=True,
    finite=False,
)

#: The options of each strip method, by method name (the registry, ``scanmesh.methods``,
#: takes them from here).
OPTIONS: dict[str, tuple[Option, ...]] = {
    "shortest-path": (
        WEIGHT_OPTION,
        Option("solver", "choice", "banded", "shortest-path solver", choices=SOLVERS),
        Option(
            "band",
            "int",
            _core.DEFAULT_BAND,
            "initial half width of the banded solver (matrix columns)",
            low=1,
            high=MAX_BAND,
        ),
        GAP_FACTOR_OPTION,
        CHECK_OPTION,
        JUMP_OPTION,
    ),
    "lookahead": (
        WEIGHT_OPTION,
        Option(
            # no upper bound: a window past a strip's end is that strip's shortest path (one
            # DP), and the core refuses a strip whose windows would cost too much
            "alpha",
            "int",
            DEFAULT_ALPHA,
            "look-ahead depth in steps (beyond a strip's length: its shortest path)",
            low=1,
        ),
        GAP_FACTOR_OPTION,
        CHECK_OPTION,
        JUMP_OPTION,
    ),
}


#: What the core's strip stage returns (``_core.strip_mesh``): faces, unused, duplicates,
#: n_strips, cost, planar_error, dropped_jumps, dropped_overlaps, trimmed, signed_area, by name.
SolvedStrips = _core.StripResult


def _expected_cost(n: int, n_lines: int, params: Mapping[str, Any]) -> float:
    """What :func:`solve_strips` costs, in the unit of ``scanmesh._interrupt.interruptible``
    (points of a linear-time stage), counted generously as path-matrix cells: the banded
    solver is near-linear (n), the whole-matrix solvers ("dp", "dijkstra") visit about
    n^2 / lines cells, the look-ahead (the method with a depth ``alpha``) n alpha^2 (at most
    the whole matrices). O(1)."""
    whole = n * (n / max(n_lines, 1))
    if "alpha" in params:
        return min(n * float(params.get("alpha", DEFAULT_ALPHA)) ** 2, whole)
    return whole if params.get("solver", "banded") in ("dp", "dijkstra") else float(n)


def solve_strips(
    points: np.ndarray,
    uv: np.ndarray,
    line_ids: np.ndarray,
    method: str,
    params: Mapping[str, Any],
    gap_factor: float,
    context: _core.ScanContext | None = None,
    counter: _core.ProgressCounter | None = None,
) -> SolvedStrips:
    """The strips between consecutive lines of ``points`` (N, 3) with planar positions
    ``uv`` (N, 2) and ``line_ids`` (N,), by ``method`` with checked ``params``
    (:data:`OPTIONS`); ``context`` solves them as part of a larger scan
    (``_core.strip_mesh``); ``counter`` counts the strips' triangles as they are solved.
    Time: that of the method, see :func:`strip_surface`."""
    n = max(len(points), 1)
    # The method's own options (OPTIONS): the core refuses one it would not use. Depths
    # and widths beyond the longest strip change nothing (each strip has fewer than
    # len(points) steps): capped, so that 10**30 is not an OverflowError.
    own: dict[str, Any] = {k: int(min(params[k], n)) for k in ("alpha", "band") if k in params}
    if "solver" in params:
        own["solver"] = params["solver"]
        if params["solver"] != "banded":
            del own["band"]
    core = _core.StripParams(
        method,
        weight=params["weight"],
        check=params["check"],
        jump_factor=params["jump_factor"],
        **own,
    )
    return _core.strip_mesh(points, uv, line_ids, core, gap_factor, context, counter)


def strip_surface(
    points: ArrayLike | PlanarScan,
    *,
    lines: ArrayLike | None = None,
    method: str = "shortest-path",
    plane: PlaneSpec = None,
    progress: Progress = False,
    **options: Any,
) -> Surface:
    """Triangulate scan-line points strip by strip.

    Parameters
    ----------
    points : (N, 3) float or PlanarScan
        Scan points, line after line (a PlanarScan is used in its own plane, with its line
        ids when it has them).
    lines : (N,) int, optional
        A line id per point (same id = one line, in input order; lines by ascending id).
        None detects the lines from the point order (:func:`scanmesh.detect_lines`).
    method : "shortest-path" or "lookahead"
        The cheapest path per strip, or Friedhoff's alpha-look-ahead.
    weight : str or mapping
        A criterion of :data:`CRITERIA` or a mapping of them to coefficients. The default
        :data:`DEFAULT_WEIGHT` (angle + 0.3 dihedral) was chosen by measuring tac_1 and the
        smallest angle of every criterion on fran_cut and a connecting-rod scan: the rod
        does not tell them apart; on fran_cut the mixture keeps the largest smallest angle
        (12.8 degrees) at 16 % less tac_1 than angle alone, where dihedral alone falls to
        4.8 degrees (figures in docs/benchmarks/speed.md).
    alpha : int
        Look-ahead depth in steps (``method="lookahead"`` only), >= 1; a depth that
        reaches a strip's end gives that strip's shortest path.
    plane : None, "best-fit", "x", "y", "z" or (3,) float
        Projection plane: lines are followed, clipped and oriented in it, and the mesh is
        counter-clockwise seen against its normal.
    gap_factor : float
        A step longer than this many median steps splits a line (a hole); strips never
        bridge it.
    solver : "banded", "dp" or "dijkstra"
        Shortest-path solver (same optimum; see :data:`SOLVERS`; shortest-path only).
    band : int
        Initial half width of the banded solver, in matrix columns (shortest-path only).
    check : bool
        Validate the mesh in the plane (O(m log m); at a million points it takes longer
        than the strips themselves) and, where lines cross or fold there, drop the
        overlapping triangles so the mesh is manifold and valid (counted in
        ``options["dropped_overlaps"]``). False skips both: no CrossingLinesWarning,
        ``options["planar_valid"]`` is None, and crossing lines leave overlaps.
    jump_factor : float
        Depth jumps (walls, steps, bores): a line is cut between consecutive points whose
        3-D step is steeper than 45 degrees and longer than this many times the median of
        the five steps around it, each piece is stitched only to the overlapping pieces
        of its neighbours, and triangles still bridging a jump by Delaunay's trimming rule
        (:data:`scanmesh.stages.options.JUMP_FACTOR`), with the pinches that leaves, are dropped
        (counted in ``options["dropped_jumps"]``; their points may end up unused). ``inf``
        keeps every strip whole.
    progress : bool or callable
        True shows progress bars; a callable taking ``stage=`` is called for the stages
        "lines" and "strips" (in points; see :func:`scanmesh.reconstruct`). Each is one
        native call, so it reports its start and its end.

    ``weight``, ``alpha``, ``gap_factor``, ``solver``, ``band``, ``check`` and
    ``jump_factor`` are the method's options (:data:`OPTIONS`); an option of the other
    method is refused.

    Returns
    -------
    Surface
        ``method`` is "shortest-path" or "lookahead"; ``options`` holds the parameters and
        ``n_lines``, ``n_strips``, ``cost`` (sum of path costs), ``unused`` ((K,) int64
        points in no triangle), ``planar_valid``, ``dropped_jumps`` and
        ``dropped_overlaps`` (triangles dropped at depth jumps and where lines cross),
        ``trimmed`` ((T,) int64, the unused points whose every triangle was dropped so);
        ``duplicates`` the points dropped for
        coinciding with the previous point of their line; ``timings`` the seconds spent
        projecting, finding lines and building strips.

    Warns
    -----
    CrossingLinesWarning
        The lines cross or fold in the plane: the warning says how many overlapping
        triangles were dropped.
    UnusedPointsWarning
        Some points are in no triangle (other than coincident duplicates and points
        trimmed with their dropped triangles).
    CoincidentPointsWarning
        Points coincide with the previous point of their line and are left out.

    Raises
    ------
    ScanmeshError
        Bad shapes or values, unknown method, weight or solver, alpha < 1, band < 1,
        fewer than two lines with two points each, or no triangle left (every one bridged
        a depth jump or overlapped others: the scan folds onto itself in the plane).
    """
    if method not in OPTIONS:
        raise ParameterError(f"method must be one of {tuple(OPTIONS)}, got {method!r}")
    params = check_options(OPTIONS[method], options, f"method {method!r}")
    scan = as_scan(points, plane=plane, lines=lines)
    return build_strips(scan, method, params, Context.of(progress))


def build_strips(
    scan: PlanarScan, method: str, params: dict[str, Any], context: Context = QUIET
) -> Surface:
    """:func:`strip_surface` of ``scan`` without its checks: ``method`` a key of
    :data:`OPTIONS` and ``params`` its options checked, as the registry
    (``scanmesh.methods``) has them. Same result, warnings and errors otherwise."""
    k = params["gap_factor"]
    pts, uv = scan.points, scan.uv
    if not _spans_plane(uv):
        raise DegenerateInputError(
            "all points are collinear after projection onto the plane: choose another plane"
        )
    t1 = time.perf_counter()
    with context.stage("lines", len(pts), blocking=True):
        ids = scan.line_ids_for(k)  # detected once per gap factor, kept with the scan
        n_lines = count_lines(ids)
    t2 = time.perf_counter()
    with context.stage("strips", len(pts)) as stage:
        work = _expected_cost(len(pts), n_lines, params)
        solve = (solve_strips, pts, uv, ids, method, params, k, None, stage.counter)
        solved = interruptible(work, *solve, watch=stage.follow)
    faces, unused, duplicates = solved.faces, solved.unused, solved.duplicates
    n_strips, cost, planar_error = solved.n_strips, solved.cost, solved.planar_error
    dropped_jumps, dropped_overlaps = solved.dropped_jumps, solved.dropped_overlaps
    trimmed = solved.trimmed
    t3 = time.perf_counter()
    if n_strips == 0:
        raise DegenerateInputError(
            "no strip to build: need two neighbouring scan lines with two points each "
            f"that overlap along the scan direction (found {n_lines} line(s))"
        )
    if len(faces) == 0:
        raise DegenerateInputError(
            f"all {dropped_jumps + dropped_overlaps} strip triangles bridged a depth jump"
            f" ({dropped_jumps}) or overlapped others in the projection plane"
            f" ({dropped_overlaps}): the scan folds onto itself there"
            f" (plane={scan.plane!r}); try another plane="
        )
    if dropped_overlaps:
        built = len(faces) + dropped_overlaps
        warnings.warn(
            f"scan lines cross or fold in the projection plane: {dropped_overlaps} of {built}"
            f" strip triangles ({100 * dropped_overlaps / built:.2g} %) overlapped there and"
            " were dropped, so the mesh is manifold and valid in the plane;"
            " see Surface.options['dropped_overlaps']",
            CrossingLinesWarning,
            stacklevel=2,
        )
    if planar_error is not None:
        # The repair leaves a valid mesh (tested); should it not, say so, never silently.
        warnings.warn(
            f"the strips are not a valid triangulation in the projection plane ({planar_error})",
            CrossingLinesWarning,
            stacklevel=2,
        )
    # Points whose every triangle was dropped (at a depth jump or an overlap) are trimmed,
    # as Delaunay's trimming reports them, not unused by the strips.
    lone = np.setdiff1d(unused, trimmed)
    lone = np.setdiff1d(lone, duplicates[:, 0]) if len(duplicates) else lone
    if len(lone):
        shown = ", ".join(str(i) for i in lone[:5])
        warnings.warn(
            f"{len(lone)} point(s) are in no strip (first: {shown}); see Surface.options['unused']",
            UnusedPointsWarning,
            stacklevel=2,
        )
    if len(duplicates):
        shown = ", ".join(f"{a}->{b}" for a, b in duplicates[:5])
        warnings.warn(
            f"{len(duplicates)} point(s) coincide in the plane with the previous point of their"
            f" line and are left out (first: {shown}); see Surface.duplicates",
            CoincidentPointsWarning,
            stacklevel=2,
        )
    return Surface(
        vertices=pts,
        faces=faces,
        method=method,
        options={
            "lines": "detected" if scan.line_ids is None else "given",
            **params,
            "plane": scan.plane,
            "n_lines": n_lines,
            "n_strips": int(n_strips),
            "cost": float(cost),
            "unused": unused,
            "planar_valid": (planar_error is None) if params["check"] else None,
            "dropped_jumps": int(dropped_jumps),
            "dropped_overlaps": int(dropped_overlaps),
            "trimmed": trimmed,
        },
        scan=scan,
        duplicates=duplicates,
        timings={**scan.timings, "lines": t2 - t1, "strips": t3 - t2},
        line_ids=scan.line_ids,
    )
