"""``reconstruct()``: one entry point for every triangulation method (see ``methods.py``)."""

from __future__ import annotations

import os
import warnings
from typing import Any

from numpy.typing import ArrayLike

from scanmesh._context import Context
from scanmesh._progress import Progress
from scanmesh.errors import (
    CurtainsWarning,
    NotAHeightFieldWarning,
    ScanmeshError,
    SliversWarning,
)
from scanmesh.formats import ScanPoints
from scanmesh.measures import (
    CURTAIN_ANGLE_DEG,
    CURTAIN_WARN_FRACTION,
    SLIVER_ANGLE_DEG,
    curtains,
)
from scanmesh.methods import DEFAULT_METHOD, METHODS, SHARED, TABLE, Keywords
from scanmesh.methods import method as find_method
from scanmesh.scan.planar import PlanarScan, planar_scan
from scanmesh.scan.projection import PlaneSpec
from scanmesh.scan.slivers import SLIVER_WARN_FRACTION, columns_advice, sliver_share
from scanmesh.scan.steep import STEEP_ANGLE_DEG, STEEP_WARN_FRACTION
from scanmesh.stages.delaunay import delaunay
from scanmesh.stages.hidden import drop_hidden
from scanmesh.surface import Surface

__all__ = ["reconstruct", "METHODS"]


def reconstruct(
    source: ArrayLike | str | os.PathLike | PlanarScan | ScanPoints,
    method: str = DEFAULT_METHOD,
    *,
    lines: ArrayLike | None = None,
    plane: PlaneSpec = None,
    max_edge: float | None = None,
    seed: int | None = None,
    progress: Progress = False,
    **options: Any,
) -> Surface:
    """Triangulate scan points.

    Parameters
    ----------
    source : (N, 3) float array, path, ScanPoints or PlanarScan
        The points, or a scan file (see :func:`scanmesh.read` for the formats; a file's scan
        lines are used unless ``lines`` is given), or what :func:`scanmesh.read` returned
        (used as the file would be: its points, line ids and recorded ``up``), or a
        :func:`scanmesh.planar_scan` made once and reused across methods (``plane`` and
        ``lines`` then belong to it).
    method : str
        ``"auto"`` (default: the method a holdout on a window of the scan prefers among
        annealing, LOP, Delaunay and shortest-path (on a range grid the first three, the
        grid built for Delaunay), see ``scanmesh.stages.choice``; the
        window's points withheld a tenth at a time, seeded by ``seed``; the Surface is the
        chosen method's, and ``options["method_choice"]`` gives ``"chosen"`` and every
        candidate's ``"holdout"`` RMS), ``"delaunay"`` (max-min angle optimum in the
        plane), ``"grid"`` (a range grid's neighbours, less the faces the scanner cannot
        have seen; scans with a grid only), ``"lookahead"`` and ``"shortest-path"``
        (Fuchs-matrix strips between
        consecutive scan lines), ``"lop"``
        (greedy tac flips), ``"anneal"`` (simulated annealing on tac), ``"optimal"``
        (certified tac optimum, small inputs only).
    lines : (N,) int, optional
        Scan line id of each point (strip methods, and LOP and annealing from
        ``initial="shortest-path"``; detected from point order when absent).
    plane : None, "best-fit", "x", "y", "z" or (3,) float
        Projection plane, obeyed as given. None (default): chosen by the data (see
        :func:`scanmesh.planar_scan`): among the direction a file records (its ``up``), the
        least-squares plane, x, y, z and the principal axes, the one over which the surface
        is most a height field (fewest steep triangles); ``options["plane_choice"]`` says
        which (``"chosen"``, ``"normal"``, and the ``"steep"`` share of every candidate).
    max_edge : float, optional
        Trimming length of the Delaunay triangulation (methods "delaunay", and "lop" and
        "anneal" from it; default 5 x median spacing; ``math.inf`` keeps the convex hull).
    seed : int, optional
        Seed for annealing and for the holdout of ``"auto"`` (default 0). The same seed
        gives the same faces.
    progress : bool or callable
        True shows a progress bar (on stderr) for every stage that runs longer than a second.
        A callable is called as ``progress(done, total, value)``. If it accepts a keyword
        argument ``stage`` (or ``**kwargs``) it is called for every stage, as
        ``progress(done, total, value, stage=name)`` with ``name`` in ``"read"`` (bytes;
        text files report every chunk), ``"choose"`` (builds: the candidates of ``"auto"``
        on the window), ``"lines"`` and ``"strips"`` (points), ``"delaunay"`` (points),
        ``"trim"`` (faces), for annealing ``"noise"`` (points: the noise estimate behind
        the tie tolerance), ``"calibrate"`` (faces: the annealer's mesh and T0),
        ``"anneal"`` (sweeps; ``value`` is the energy; every ~20 ms; a callable that takes
        ``seconds_left`` gets the estimated time left) and ``"polish"`` (faces: the best
        state, polished), ``"steep"`` (faces: the height-field check below) and, from
        :meth:`Surface.save` / the command, ``"write"`` (faces; the command also reports
        ``"quality"`` and, with --preview, ``"preview"``). Otherwise it is called for
        annealing only, as ``progress(sweeps_done, sweeps_total, energy)``. Within a stage
        ``total`` never changes, ``done`` never decreases and the last call has ``done ==
        total`` (annealing stopped early by ``time_limit`` or ``patience``: the sweeps that
        ran; ``options["stopped"]`` says why); stages that are
        one native call or one pass (lines, strips, Delaunay, trimming, noise, calibrate,
        polish, steep, quality, preview) report their start and end only. See
        ``scanmesh._progress``.
    **options
        Method options, each with its type, range, default and doc in
        ``scanmesh.methods.TABLE[method].options``. ``anneal``: ``initial`` ("delaunay",
        "shortest-path", or a Surface built on the same PlanarScan), ``sweeps``, ``p``,
        ``sliver_guard``, ``chains``, ``tiles``, ``time_limit`` (seconds of sweeps, then
        the best state so far; ``options["stopped"]`` says what ended the run), ...;
        ``lop``: ``initial``, ``criterion`` ("tac" or "max-min"), ``p``, ``sliver_guard``,
        ``tie_tolerance``, ``curtain_angle`` (as annealing's: no flip makes a curtain where
        the scan knows its line of sight, a recorded ``up`` or a range grid);
        ``lookahead``: ``weight``, ``alpha``, ``gap_factor``, ``check``;
        ``shortest-path``: ``weight``, ``solver``, ``band``, ``gap_factor``, ``check``;
        ``optimal``: ``p``, ``time_limit``, ``strengthen``, ``incumbent``. A keyword the
        chosen method does not use is refused (``scanmesh.methods.TABLE`` says which method
        uses which), as are ``lines``, ``max_edge`` and ``seed`` where it does not.

    Returns
    -------
    Surface
        Faces over the input points with ``method``, ``options``, ``timings`` and, for
        annealing, ``trace``. Where the scan records its line of sight (a file's ``up``, a
        simulated range scan) and was projected on another plane, no face hides a sample
        from the scanner (``stages.hidden``; ``options["hidden_dropped"]`` counts those
        dropped).

    Raises
    ------
    ScanmeshError
        Bad points, a bad file, an unknown method or option.
    KeyboardInterrupt
        Ctrl-C during annealing (returns control within about 20 ms).

    Warns
    -----
    CurtainsWarning
        Faces within ``measures.CURTAIN_ANGLE_DEG`` (5 degrees) of the line of sight (the
        scan's recorded ``up``, else the projection normal) cover more than
        ``measures.CURTAIN_WARN_FRACTION`` (0.5 %) of the area; ``options["curtains"]``
        always gives their ``count``, ``area``, ``fraction`` and the ``sight`` used.
    SliversWarning
        More than ``scan.slivers.SLIVER_WARN_FRACTION`` (75 %) of the triangles are slivers
        (smallest angle below ``measures.SLIVER_ANGLE_DEG``, 5 degrees): the columns were
        probably read in the wrong order, or the plane sees the points in far-apart rows;
        the message names the likely cause and what to try. Not said where the next is
        (steep triangles name the plane as the cause).
    NotAHeightFieldWarning
        More than ``scan.steep.STEEP_WARN_FRACTION`` (10 %) of the triangles are steeper than
        ``scan.steep.STEEP_ANGLE_DEG`` (75 degrees) over the projection plane (see
        ``Surface.steep_fraction``), and of the points' Delaunay triangulation there too (so
        a method's own slivers over a height field do not warn).
    """
    spec = find_method(method)
    params = spec.check(options, {"lines": lines, "max_edge": max_edge, "seed": seed})
    context = Context.of(progress, None if seed is None else SHARED["seed"].check(seed))
    # The one place the points are read (scan.read_scan_file), checked and projected.
    scan = planar_scan(source, plane=plane, lines=lines, progress=progress)
    surface = spec.run(scan, params, Keywords(max_edge=max_edge, context=context))
    surface = drop_hidden(scan, surface)
    if scan.choice is not None:
        choice = scan.choice.as_dict(scan.frame.normal)
        surface.options = {**surface.options, "plane_choice": choice}
    _report_curtains(scan, surface)
    with context.stage("steep", len(surface.faces), blocking=True):
        steep = surface.steep_fraction
        slivers = sliver_share(surface.vertices, surface.faces)
    if steep is not None and steep > STEEP_WARN_FRACTION and _points_steep(scan, surface):
        warnings.warn(
            f"{100 * steep:.0f} % of the triangles are steep (normal more than"
            f" {STEEP_ANGLE_DEG:g} deg from the projection normal): the surface is probably"
            f" not a height field over this plane (plane={scan.plane!r}); try another plane=,"
            " e.g. 'x', 'y', 'z' or a normal vector",
            NotAHeightFieldWarning,
            stacklevel=2,
        )
    elif slivers > SLIVER_WARN_FRACTION:  # not the plane, then: most likely the columns
        warnings.warn(
            f"{100 * slivers:.0f} % of the triangles are slivers (smallest angle below"
            f" {SLIVER_ANGLE_DEG:g} deg): unless the scan lines truly lie that far apart"
            " compared to the points along them, " + columns_advice(scan.points, scan.plane),
            SliversWarning,
            stacklevel=2,
        )
    return surface


def _report_curtains(scan: PlanarScan, surface: Surface) -> None:
    """``options["curtains"]``: the faces within CURTAIN_ANGLE_DEG of the line of sight, and
    a CurtainsWarning naming them when they cover more than CURTAIN_WARN_FRACTION of the
    area."""
    recorded = scan.up is not None
    found = curtains(surface.vertices, surface.faces, scan.sight)
    report = {
        **found.as_dict(),
        "sight": "recorded up" if recorded else "projection normal",
        "angle_deg": CURTAIN_ANGLE_DEG,
    }
    surface.options = {**surface.options, "curtains": report}
    if found.fraction > CURTAIN_WARN_FRACTION:
        shown = ", ".join(str(f) for f in found.faces[:5])
        warnings.warn(
            f"{found.count} face(s) within {CURTAIN_ANGLE_DEG:g} deg of the line of sight"
            f" ({report['sight']}) cover {100 * found.fraction:.2g} % of the area"
            f" ({found.area:.6g}; largest faces: {shown}): curtains the scanner's rays pass"
            " along, probably hung across depth jumps; a gridded scan's method 'grid' or"
            " 'delaunay' (trimmed) keeps fewer",
            CurtainsWarning,
            stacklevel=3,
        )


def _points_steep(scan: PlanarScan, surface: Surface) -> bool:
    """Whether the points themselves are steep over the scan's plane, not only the faces a
    method chose: their Delaunay triangulation there (fewest slivers of any triangulation)
    is steep too. A method's own slivers (annealing's, a strip's across a gap) can stand
    steep over a smooth height field; the plane choice's quick triangulation measured the
    chosen plane already."""
    built = TABLE.get(surface.method)
    if built is not None and built.max_min_angle:
        return True
    if scan.choice is not None and scan.choice.steep.get(scan.choice.chosen) is not None:
        return scan.choice.steep[scan.choice.chosen] > STEEP_WARN_FRACTION
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # said once already, by the method
        try:
            base = delaunay(scan)
        except ScanmeshError:
            return True
    return base.steep_fraction is not None and base.steep_fraction > STEEP_WARN_FRACTION
