"""The holdout error: the truth-free judge of a method. Withhold a share of the points (or
of the scan lines), reconstruct from the rest, and measure how far the withheld points lie
from the mesh along the projection normal. The one judge that runs ``reconstruct``."""

from __future__ import annotations

import math
import os
from typing import Any

import numpy as np

from scanmesh._checks import as_points
from scanmesh.errors import ParameterError
from scanmesh.formats import read
from scanmesh.judge import Seen, distances, rms, withhold
from scanmesh.methods import used_keywords
from scanmesh.reconstruction import reconstruct
from scanmesh.scan.lines import GAP_FACTOR, as_line_ids
from scanmesh.scan.planar import as_scan

#: What :func:`holdout_error` measures, for reports.
HOLDOUT_MEASURE = (
    "distance along the projection normal from withheld scan points to the mesh"
    " reconstructed from the other points"
)

#: ``by=`` values of :func:`holdout_error`.
HOLDOUT_BY = ("points", "lines")


def holdout_error(
    points: Any,
    method: str = "anneal",
    fraction: float = 0.1,
    seed: int = 0,
    by: str = "points",
    **options: Any,
) -> dict[str, Any]:
    """Error of a reconstruction method without a true surface: withhold points, measure them.

    A seeded random ``fraction`` of the points (``by="points"``) or of the scan lines
    (``by="lines"``, whole lines, which tests the mesh between lines) is withheld; the rest
    is reconstructed with ``method`` and ``options`` (as :func:`scanmesh.reconstruct`,
    with ``seed`` for annealing), and each withheld point's distance to the mesh along the
    projection normal is measured: the height of the mesh straight above or below it. A
    withheld point outside the mesh's planar domain (beyond its outline or in a hole it
    leaves) has no such distance and is counted in ``outside``. Withheld points carry the
    scan's noise, so the figures include it: compare methods on one scan and seed.

    Parameters
    ----------
    points : (N, 3) float or path
        The scan (a file's scan lines are used unless ``lines`` is in ``options``).
    method : str
        A method of :func:`scanmesh.reconstruct`.
    fraction : float
        Share withheld, strictly between 0 and 1 (of the points, or of the lines).
    seed : int
        Seeds the choice of withheld points and the reconstruction.
    by : "points" or "lines"
        Withhold single points, or whole scan lines (lines from ``options["lines"]``, the
        file, or detected from the point order).
    **options
        Passed to :func:`scanmesh.reconstruct` (``plane``, ``lines``, ``max_edge``, method
        options).

    Returns
    -------
    dict
        ``rms``, ``p99``, ``max``: of the distances (model units) of the withheld points
        inside the domain; ``n_withheld``, ``n_measured``, ``outside`` (counts);
        ``method``, ``by``, ``fraction``, ``seed``, ``measure`` (:data:`HOLDOUT_MEASURE`);
        ``surface``: the mesh reconstructed from the kept points (faces index the kept
        points, whose indices into ``points`` are ``kept``). O(reconstruction + N).

    Raises
    ------
    ParameterError
        A bad ``fraction`` or ``by``, or a share that leaves nothing withheld or kept.
    """
    if by not in HOLDOUT_BY:
        raise ParameterError(f"by must be one of {HOLDOUT_BY}, got {by!r}")
    frac = float(fraction) if isinstance(fraction, (int, float, np.integer, np.floating)) else None
    if frac is None or not 0.0 < frac < 1.0:
        raise ParameterError(
            f"fraction must be a number strictly between 0 and 1, got {fraction!r}"
        )
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ParameterError(f"seed must be a whole number >= 0, got {seed!r}")
    lines = options.pop("lines", None)
    if isinstance(points, (str, os.PathLike)):
        scan = read(points)
        pts, lines = scan.points, scan.line_ids if lines is None else lines
    else:
        pts = as_points(points)
    plane = options.get("plane")
    if lines is not None:
        lines = as_line_ids(lines, len(pts))
    rng = np.random.default_rng(seed)
    if by == "lines":
        if lines is None:
            # detected on all points (withheld lines need ids); the kept points are projected
            # by reconstruct on their own (their plane, their frame), and strips get these ids
            lines = as_scan(pts, plane=plane).detected_line_ids(GAP_FACTOR)
        ids = np.unique(lines)
        n_out = int(round(frac * len(ids)))
        out_ids = rng.choice(ids, size=n_out, replace=False) if n_out else ids[:0]
        withheld = np.isin(lines, out_ids)
        unit = "lines"
        n_units = len(ids)
    else:
        n_out = int(round(frac * len(pts)))
        withheld = withhold(len(pts), n_out, rng)
        unit = "points"
        n_units = len(pts)
    if n_out == 0 or n_out == n_units:
        raise ParameterError(
            f"fraction {frac:g} of {n_units} {unit} withholds {n_out}: nothing to measure or"
            " nothing to reconstruct from"
        )
    kept = np.flatnonzero(~withheld)
    out = np.flatnonzero(withheld)
    # lines and seed go to the method only where it uses them (it refuses the others)
    used = used_keywords(method, options)
    shared: dict[str, Any] = {"seed": seed} if "seed" in used else {}
    if "lines" in used and lines is not None:
        shared["lines"] = lines[kept]
    surface = reconstruct(pts[kept], method, **shared, **options)
    got, face = distances(pts[out], Seen.of(surface))  # surface.vertices: pts[kept]
    inside = face >= 0
    dist = got[inside]
    measured = len(dist) > 0
    return {
        "rms": rms(dist),
        "p99": float(np.percentile(dist, 99)) if measured else math.nan,
        "max": float(dist.max()) if measured else math.nan,
        "n_withheld": int(len(out)),
        "n_measured": int(len(dist)),
        "outside": int((~inside).sum()),
        "method": method,
        "by": by,
        "fraction": frac,
        "seed": int(seed),
        "measure": HOLDOUT_MEASURE,
        "surface": surface,
        "kept": kept,
    }
