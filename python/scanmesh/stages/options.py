"""What the stages share: the Option records of keywords several methods take (``p``,
``sliver_guard``, ``tie_tolerance``, ``curtain_angle``, ``seed``, ``max_edge``), the
trimming constants read from the core, the line of sight of the curtain rule, and the check
that an optimizer starts from a planar triangulation."""

from __future__ import annotations

import numpy as np

from scanmesh import _core
from scanmesh._checks import Option
from scanmesh.errors import ParameterError
from scanmesh.scan.planar import PlanarScan
from scanmesh.scan.spacing import MAX_EDGE_FACTOR as MAX_EDGE_FACTOR  # defined with the spacings
from scanmesh.surface import Surface

#: A triangle whose longest 3-D edge exceeds this multiple of the local 3-D spacing (the
#: median edge length at its best-sampled corner) bridges a depth jump and is dropped
#: whenever ``max_edge`` is finite.
JUMP_FACTOR: float = _core.DEFAULT_JUMP_FACTOR

#: A triangle at any slope whose longest 3-D edge exceeds this multiple of the 3-D spacing
#: across lines at its best-sampled corner bridges a gap (a rung or fan across a missed
#: stretch of a line, a sheet over a hole narrower than ``max_edge``) and is dropped with
#: the depth jumps.
BRIDGE_FACTOR: float = _core.DEFAULT_BRIDGE_FACTOR

#: A triangle whose planar area exceeds this multiple of the local triangle area (the median
#: over its corners of the lower median of the areas at each) covers missing samples (a
#: hole or slot narrower than ``max_edge``, at one height) and is dropped with the depth jumps.
HOLE_FACTOR: float = _core.DEFAULT_HOLE_FACTOR


#: ``max_edge``, the shared trimming keyword: None means MAX_EDGE_FACTOR x median spacing.
MAX_EDGE_OPTION = Option(
    "max_edge",
    "float",
    None,
    "drop triangles with a longer planar edge (input units; default 5 x median spacing,"
    " math.inf keeps the convex hull)",
    low=0.0,
    low_open=True,
    finite=False,
)


#: Every annealing parameter's default, by name, as the Rust core declares them
#: (``AnnealParams``, the one declaration); LOP shares ``p``, ``sliver_guard`` and
#: ``tie_tolerance``.
CORE_ANNEAL_DEFAULTS: dict[str, int | float | bool] = _core.AnnealParams().as_dict()

#: The tac exponent p of the energy sum tac^p (LOP and annealing).
P_OPTION = Option(
    "p", "float", CORE_ANNEAL_DEFAULTS["p"], "exponent p of the energy sum tac^p", low=1.0
)

#: Energy ties break toward well-shaped triangles (LOP and annealing's polish).
SLIVER_GUARD_OPTION = Option(
    "sliver_guard",
    "bool",
    CORE_ANNEAL_DEFAULTS["sliver_guard"],
    "break energy ties toward the larger smallest angle",
)

#: Energy changes of at most this size are ties (LOP and annealing).
TIE_TOLERANCE_OPTION = Option(
    "tie_tolerance",
    "float",
    CORE_ANNEAL_DEFAULTS["tie_tolerance"],
    "energy changes of at most this size (radians^p) are ties",
    low=0.0,
)

#: No flip brings a face nearer the line of sight than this (LOP and annealing; the core's
#: ``CURTAIN_ANGLE_DEG``, 90 degrees less the grid triangulation's largest turn), where the
#: scan knows its line of sight (:func:`curtain_sight`).
CURTAIN_ANGLE_OPTION = Option(
    "curtain_angle",
    "float",
    CORE_ANNEAL_DEFAULTS["curtain_angle"],
    "refuse flips that bring a face's plane within this angle (degrees) of the line of sight"
    " and nearer it than before (0: off)",
    low=0.0,
    high=90.0,
    high_open=True,
)

#: ``seed``, the shared keyword of the random methods: None means 0.
SEED_OPTION = Option(
    "seed", "int", None, "seed of every random choice (default 0)", low=0, high=2**64 - 1
)


def curtain_sight(scan: PlanarScan) -> np.ndarray | None:
    """(3,) float64 line of sight LOP and annealing refuse curtains along, or None (no such
    rule): ``scan.sight`` where the scan knows where its rays came from, a recorded ``up``
    or a range grid (whose triangulation judged its faces by the same sight). Elsewhere the
    projection normal is no line of sight: faces steep over it are real surface seen at a
    grazing angle, and holding flips off them raised fran_cut's holdout error
    (docs/benchmarks/curtains.md)."""
    if scan.up is None and scan.grid is None:
        return None
    return scan.sight


def planar_start(initial: Surface, stage: str) -> Surface:
    """``initial`` if it carries the scan it was built on, else ParameterError."""
    if not isinstance(initial, Surface) or initial.scan is None:
        raise ParameterError(
            f"{stage} starts from a planar triangulation with its scan (a Surface from"
            f" delaunay() or the strip methods), got {initial!r}"
        )
    return initial
