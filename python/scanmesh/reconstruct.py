"""``reconstruct()``: one entry point for every triangulation method."""

from __future__ import annotations

import os
import time
import warnings
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from scanmesh._checks import as_points
from scanmesh._progress import Progress, Stage, anneal_progress
from scanmesh.anneal import anneal_surface, lop_surface
from scanmesh.delaunay import delaunay
from scanmesh.errors import NotAHeightFieldWarning, ParameterError
from scanmesh.projection import PlaneSpec
from scanmesh.surface import STEEP_ANGLE_DEG, STEEP_WARN_FRACTION, Surface

#: Methods of :func:`reconstruct`, fast to slow.
METHODS = ("delaunay", "lookahead", "shortest-path", "lop", "anneal", "optimal")

#: Initial triangulations annealing and LOP can start from.
INITIALS = ("delaunay", "shortest-path")


def _load(
    source: ArrayLike | str | os.PathLike, progress: Progress
) -> tuple[np.ndarray, np.ndarray | None]:
    if isinstance(source, (str, os.PathLike)):
        from scanmesh.readers import read

        scan = read(source, progress=progress)
        return scan.points, scan.line_ids
    return as_points(source), None


def _strips(
    points: np.ndarray, method: str, lines: Any, plane: PlaneSpec, options: dict,
    progress: Progress,
) -> Surface:
    from scanmesh.strips import strip_surface

    return strip_surface(
        points, lines=lines, method=method, plane=plane, progress=progress, **options
    )


def reconstruct(
    source: ArrayLike | str | os.PathLike,
    method: str = "anneal",
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
    source : (N, 3) float array or path
        The points, or a scan file (see :func:`scanmesh.read` for the formats; a file's scan
        lines are used unless ``lines`` is given).
    method : str
        ``"delaunay"`` (max-min angle optimum in the plane), ``"lookahead"`` and
        ``"shortest-path"`` (Fuchs-matrix strips between consecutive scan lines), ``"lop"``
        (greedy tac flips), ``"anneal"`` (simulated annealing on tac), ``"optimal"``
        (certified tac optimum, small inputs only).
    lines : (N,) int, optional
        Scan line id of each point (strip methods; detected from point order when absent).
    plane : None, "best-fit", "x", "y", "z" or (3,) float
        Projection plane of the planar methods (default: least-squares plane).
    max_edge : float, optional
        Trimming length for Delaunay-based methods (default 5 x median spacing; ``math.inf``
        keeps the convex hull).
    seed : int, optional
        Seed for annealing (default 0). The same seed gives the same faces.
    progress : bool or callable
        True shows a progress bar (on stderr) for every stage that runs longer than a second.
        A callable is called as ``progress(done, total, value)``. If it accepts a keyword
        argument ``stage`` (or ``**kwargs``) it is called for every stage, as
        ``progress(done, total, value, stage=name)`` with ``name`` in ``"read"`` (bytes;
        text files report every chunk), ``"lines"`` and ``"strips"`` (points), ``"delaunay"``
        (points), ``"trim"`` (faces), ``"anneal"`` (sweeps; ``value`` is the energy; every
        ~20 ms), ``"steep"`` (faces: the height-field check below) and, from
        :meth:`Surface.save` / the command, ``"write"`` (faces). Otherwise
        it is called for annealing only, as ``progress(sweeps_done, sweeps_total, energy)``.
        Within a stage ``done`` never decreases and the last call has ``done == total``;
        stages that are one native call or one pass (lines, strips, Delaunay, trimming,
        steep) report their start and end only. See ``scanmesh._progress``.
    **options
        Method options. ``anneal``: ``initial`` ("delaunay" or "shortest-path"), ``sweeps``,
        ``p``, ``sliver_guard``, ... (see :data:`scanmesh.anneal.ANNEAL_DEFAULTS`). ``lop``:
        ``initial``, ``criterion`` ("tac" or "max-min"), ``p``, ``sliver_guard``. Strip
        methods: ``weight``, ``alpha``. ``optimal``: ``p``, ``time_limit``.

    Returns
    -------
    Surface
        Faces over the input points with ``method``, ``options``, ``timings`` and, for
        annealing, ``trace``.

    Raises
    ------
    ScanmeshError
        Bad points, a bad file, an unknown method or option.
    KeyboardInterrupt
        Ctrl-C during annealing (returns control within about 20 ms).

    Warns
    -----
    NotAHeightFieldWarning
        More than ``surface.STEEP_WARN_FRACTION`` (10 %) of the triangles are steeper than
        ``surface.STEEP_ANGLE_DEG`` (75 degrees) over the projection plane (see
        ``Surface.steep_fraction``).
    """
    if method not in METHODS:
        raise ParameterError(f"unknown method {method!r}; choose one of {', '.join(METHODS)}")
    t0 = time.perf_counter()
    points, file_lines = _load(source, progress)
    if lines is None:
        lines = file_lines
    t_read = time.perf_counter() - t0

    def initial_surface(name: str) -> Surface:
        if name not in INITIALS:
            raise ParameterError(f"unknown initial {name!r}; choose one of {', '.join(INITIALS)}")
        if name == "delaunay":
            return delaunay(points, plane=plane, max_edge=max_edge, progress=progress)
        return _strips(points, "shortest-path", lines, plane, {}, progress)

    if method == "delaunay":
        _no_options(method, options)
        surface = delaunay(points, plane=plane, max_edge=max_edge, progress=progress)
    elif method in ("lookahead", "shortest-path"):
        surface = _strips(points, method, lines, plane, options, progress)
    elif method == "lop":
        start = initial_surface(options.pop("initial", "delaunay"))
        surface = lop_surface(start, **options)
    elif method == "anneal":
        start = initial_surface(options.pop("initial", "delaunay"))
        surface = anneal_surface(
            start, seed=seed, progress=anneal_progress(progress), **options
        )
    else:
        from scanmesh.optimal import optimal_surface

        surface = optimal_surface(points, plane=plane, **options)
    if t_read > 0 and isinstance(source, (str, os.PathLike)):
        surface.timings = {"read": t_read, **surface.timings}
    if surface.line_ids is None and lines is not None:
        surface.line_ids = np.asarray(lines)
    with Stage(progress, "steep", len(surface.faces), blocking=True):
        steep = surface.steep_fraction
    if steep is not None and steep > STEEP_WARN_FRACTION:
        warnings.warn(
            f"{100 * steep:.0f} % of the triangles are steep (normal more than"
            f" {STEEP_ANGLE_DEG:g} deg from the projection normal): the surface is probably"
            f" not a height field over this plane (plane={plane!r}); try another plane=,"
            " e.g. 'x', 'y', 'z' or a normal vector",
            NotAHeightFieldWarning,
            stacklevel=2,
        )
    return surface


def _no_options(method: str, options: dict[str, Any]) -> None:
    if options:
        raise ParameterError(f"method {method!r} takes no option(s) {sorted(options)}")
