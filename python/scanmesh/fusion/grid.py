"""The voxel grid :func:`scanmesh.merge` fuses into: its options (``voxel``,
``truncation``, ``max_voxels``, ``refine``, ``simplify``; one table for the function and
the ``scanmesh merge`` command, whose flags and help come from it) and its size, worked
out and refused before anything is allocated.

A grid holds the part's box plus a margin of ``truncation + 2`` voxels on every side and
two more nodes per axis, so however coarse the voxel, a grid has at least
``ceil(2 truncation + 4) + 3`` nodes along each axis (13 at the default truncation):
``max_voxels`` below that cube is refused, as is a voxel coarser than every view (the part
would fall between two nodes: nothing to extract).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from scanmesh._checks import Option
from scanmesh.errors import ParameterError

#: Grid nodes allocated at most (blocks of 8³ near the surfaces; 9 bytes each), unless
#: ``max_voxels`` says otherwise.
MAX_VOXELS = 64_000_000

#: Nodes along a side of the grid's blocks (the core's ``fusion::blocks::BLOCK``).
BLOCK = 8

#: The default truncation of the signed distance, in voxels.
TRUNCATION_VOXELS = 3.0

#: The default tolerance of the extracted mesh's simplification, in voxels. Measured
#: (docs/benchmarks/merge.md): on the dragon's stand series at a 1 mm voxel, 0.02, 0.03,
#: 0.05, 0.1 and 0.2 kept 65, 54, 42, 30 and 21 % of the faces at a holdout RMS 0.06,
#: 0.2, 0.6, 2.3 and 8.5 % above the unsimplified mesh's; on the simulated conrod and
#: fandisk 0.05 kept 18 and 10 % of the faces and lowered their RMS (the collapses'
#: planes average the vertices' noise), their creases as before.
SIMPLIFY_VOXELS = 0.05

#: merge's keywords besides the views, their poses and ``toward``, as the command's flags.
OPTIONS: tuple[Option, ...] = (
    Option(
        "voxel",
        "float",
        None,
        "grid spacing in world units (default: the views' ray spacing, made larger until"
        " the grid fits max_voxels)",
        low=0.0,
        low_open=True,
        automatic=True,
    ),
    Option(
        "truncation",
        "float",
        TRUNCATION_VOXELS,
        "how far in front of a view's surface its distance counts, in voxels",
        low=1.0,
    ),
    Option(
        "max_voxels",
        "int",
        MAX_VOXELS,
        "most grid nodes allocated (the blocks of 8³ nodes near the samples; 9 bytes each)",
        low=1,
    ),
    Option(
        "refine",
        "bool",
        False,
        "first refine the poses by point-to-plane ICP between overlapping views (the first"
        " view fixed); the residual before and after is reported",
    ),
    Option(
        "simplify",
        "float",
        SIMPLIFY_VOXELS,
        "collapse edges of the extracted mesh while every vertex of it stays within this"
        " many voxels of the result (flat and smooth parts get larger faces; 0: one face"
        " pair per voxel crossing)",
        low=0.0,
    ),
)

#: The options by name.
TABLE: dict[str, Option] = {option.name: option for option in OPTIONS}


@dataclass(frozen=True)
class Grid:
    """Where the nodes are: the first node, the spacing and the node count per axis."""

    #: (3,) float64 world position of node (0, 0, 0)
    origin: np.ndarray
    #: distance between neighbouring nodes (world units)
    voxel: float
    #: nodes along x, y and z
    dims: tuple[int, int, int]

    @property
    def nodes(self) -> int:
        """Number of nodes."""
        return math.prod(self.dims)


def node_counts(extent: np.ndarray, voxel: float, truncation: float) -> list[float]:
    """Nodes along each axis for a part of ``extent`` (3,) at ``voxel`` (floats: inf when
    they cannot be counted, so the caller refuses instead of casting). O(1)."""
    margin = (truncation + 2.0) * voxel
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        cells = np.ceil((np.asarray(extent, dtype=np.float64) + 2 * margin) / voxel) + 2
    return [float(c) if math.isfinite(c) else math.inf for c in cells]


def _count(counts: Sequence[float]) -> float:
    """Nodes of the whole blocks of 8³ covering a grid of ``counts`` nodes along each axis
    (what the fusion allocates at most), exact while finite (Python integers), inf
    otherwise."""
    if not all(math.isfinite(c) for c in counts):
        return math.inf
    total = math.prod(-(-int(c) // BLOCK) * BLOCK for c in counts)
    return float(total) if total.bit_length() < 1000 else math.inf


def near_samples(points: np.ndarray, origin: np.ndarray, voxel: float) -> int:
    """Grid nodes in the blocks holding a sample of ``points`` (N, 3) or next to one (26
    neighbours): what the fusion allocates at least, as it allocates the blocks a
    surface's band crosses. O(N log N)."""
    keys = np.unique(np.floor((points - origin) / (BLOCK * voxel)).astype(np.int64), axis=0)
    offsets = np.array([[i, j, k] for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1)])
    near = np.unique((keys[:, None, :] + offsets[None]).reshape(-1, 3), axis=0)
    return len(near) * BLOCK**3


def _needed(
    lo: np.ndarray,
    extent: np.ndarray,
    voxel: float,
    truncation: float,
    max_voxels: int,
    samples: np.ndarray | None,
) -> float:
    """Nodes the grid at ``voxel`` allocates at least: the whole box where it fits
    ``max_voxels``, else (``samples`` given and the box countable) the blocks near them."""
    box = _count(node_counts(extent, voxel, truncation))
    if box <= max_voxels or samples is None or box > 2.0**62:
        return box
    return float(min(box, near_samples(samples, _origin(lo, voxel, truncation), voxel)))


def _origin(lo: np.ndarray, voxel: float, truncation: float) -> np.ndarray:
    # half a voxel more on the low side: the part's extreme faces (and CAD faces on round
    # coordinates) fall between node layers, not on one, where the sign of the distance
    # would be noise and the surface would fold between two layers of cells
    return lo - (truncation + 2.0) * voxel - 0.5 * voxel


def smallest_grid(truncation: float) -> int:
    """Nodes along each axis of the coarsest grid (a part smaller than one voxel)."""
    return math.ceil(2 * truncation + 4) + 3


def grid_for(
    lo: np.ndarray,
    extent: np.ndarray,
    view_size: float,
    voxel: float | None,
    spacing: float,
    truncation: float,
    max_voxels: int,
    unit: float = 1.0,
    shown: float | None = None,
    samples: np.ndarray | None = None,
) -> Grid:
    """The grid over the box ``lo``, ``lo + extent`` (world units), or ParameterError.

    ``voxel`` None: the views' ray ``spacing``, made larger until the grid's whole box has
    at most ``max_voxels`` nodes (so whatever blocks the views allocate fit). A given
    ``voxel`` whose grid surely exceeds ``max_voxels`` (the box, or with ``samples``
    (N, 3) the blocks near them, a lower bound of what the fusion allocates: beyond it the
    core refuses as it allocates) is refused,
    naming both; so is any voxel of at least ``view_size`` (the largest extent of a single
    view), which leaves no node inside the part. ``unit`` turns world units back into the
    caller's for messages (merge works on the views scaled by a power of two), ``shown``
    is the voxel as the caller gave it. O(1)."""
    side = smallest_grid(truncation)
    count = f"{side:,}" if side < 10**6 else f"{side:.3g}"
    smallest = (
        f"the smallest grid at truncation={truncation:g} has {count} nodes along each axis"
        " (the part's box and a margin of truncation + 2 voxels on every side)"
    )
    if voxel is None:
        if _count([side] * 3) > max_voxels:
            raise ParameterError(f"max_voxels={max_voxels:,} is too small: {smallest}")
        size = spacing
        nodes = _count(node_counts(extent, size, truncation))
        if math.isinf(nodes):  # views of very different scales: start from the longest side
            size = max(size, float(np.max(extent)) / max_voxels ** (1 / 3))
            nodes = _count(node_counts(extent, size, truncation))
        while nodes > max_voxels:  # each step at least 1 % coarser: the count falls to `side`³
            size *= max((nodes / max_voxels) ** (1 / 3), 1.0) * 1.01
            nodes = _count(node_counts(extent, size, truncation))
        if size >= view_size:
            raise ParameterError(
                f"the views span {_shown(extent * unit)}, but a grid of at most"
                f" max_voxels={max_voxels:,} nodes over them needs a voxel of {size * unit:.4g},"
                f" coarser than any view ({view_size * unit:.4g} across): are the poses in"
                " the views' units? (raise max_voxels or give voxel)"
            )
    else:
        size, shown = voxel, voxel * unit if shown is None else shown
        if size >= view_size:
            raise ParameterError(
                f"voxel={float(shown)!r} is coarser than any view ({view_size * unit:.4g}"
                " across): the surface would fall between the nodes; use a voxel near the"
                f" views' ray spacing ({spacing * unit:.4g})"
            )
        counts = node_counts(extent, size, truncation)
        nodes = _needed(lo, extent, size, truncation, max_voxels, samples)
        if nodes > max_voxels:
            need = float(np.max(extent)) / (max_voxels ** (1 / 3))
            fits = _count([side] * 3) <= max_voxels
            hint = f"use voxel={need * unit:.3g} or more" if fits else smallest
            sizes = " x ".join(f"{c:.0f}" if c < 1e15 else f"{c:.3g}" for c in counts)
            raise ParameterError(
                f"voxel={float(shown)!r} at truncation={truncation:g} makes a grid of {sizes}"
                f" nodes ({nodes:.4g} allocated near the samples), over"
                f" max_voxels={max_voxels:,}; {hint}"
            )
    dims = tuple(int(c) for c in node_counts(extent, size, truncation))
    return Grid(_origin(lo, size, truncation), size, dims)  # type: ignore[arg-type]


def _shown(extent: np.ndarray) -> str:
    return " x ".join(f"{e:.4g}" for e in extent)
