"""Lawson's local optimization procedure (LOP) on a planar triangulation: flip while it helps.

From a Delaunay or strip triangulation, an interior edge is flipped while the flip lowers
sum tac^p (the tac order, annealing at temperature zero) or raises the smallest planar
angle ("max-min", which converges to the Delaunay triangulation). Flips are judged on the
scan's own planar coordinates, the ones the initial triangulation was built on.
"""

from __future__ import annotations

import time

from scanmesh import _core
from scanmesh._checks import Option, check_options
from scanmesh._interrupt import interruptible
from scanmesh.stages.options import (
    CURTAIN_ANGLE_OPTION,
    P_OPTION,
    SLIVER_GUARD_OPTION,
    TIE_TOLERANCE_OPTION,
    curtain_sight,
    planar_start,
)
from scanmesh.surface import Surface

#: LOP's expected cost per point, in the units of :data:`scanmesh._interrupt.THREAD_MIN_COST`
#: (a linear stage's point, about a microsecond).
LOP_COST = 50

#: LOP's options.
OPTIONS: tuple[Option, ...] = (
    Option(
        "criterion",
        "choice",
        "tac",
        "flip to lower sum tac^p ('tac') or to raise the smallest planar angle ('max-min')",
        choices=("tac", "max-min"),
    ),
    P_OPTION,
    SLIVER_GUARD_OPTION,
    TIE_TOLERANCE_OPTION,
    CURTAIN_ANGLE_OPTION,
)


def lop_surface(
    initial: Surface,
    *,
    criterion: str = "tac",
    p: float = 1.0,
    sliver_guard: bool = True,
    tie_tolerance: float = TIE_TOLERANCE_OPTION.default,
    curtain_angle: float = CURTAIN_ANGLE_OPTION.default,
) -> Surface:
    """Lawson's LOP from ``initial``: flip while a flip improves ``criterion``.

    ``criterion="tac"`` minimizes sum tac^p (annealing at T = 0; energy ties go to the larger
    smallest angle when ``sliver_guard``; no flip brings a face within ``curtain_angle``
    degrees of the line of sight and nearer it than before, where the scan knows it:
    ``stages.options.curtain_sight``);
    ``"max-min"`` maximizes the smallest angle in the
    projection plane and so converges to the Delaunay triangulation. Flips are judged in
    ``initial.scan``'s planar coordinates. O(flips x log m) after an O(m) start; the flip
    budget is finite (ARCHITECTURE.md, "Why").

    Returns
    -------
    Surface
        method "lop", on the same scan, with ``options["flips"]`` the flips made.
    """
    start = planar_start(initial, "LOP")
    params = check_options(
        OPTIONS,
        {
            "criterion": criterion,
            "p": p,
            "sliver_guard": sliver_guard,
            "tie_tolerance": tie_tolerance,
            "curtain_angle": curtain_angle,
        },
        "LOP",
    )
    scan = start.scan
    assert scan is not None
    t0 = time.perf_counter()
    # in a worker above a thousand points: the default's 20,000-point parts took 1 s
    # under load, and Ctrl-C waited for it
    faces, flips = interruptible(
        LOP_COST * len(scan.points),
        lambda: _core.lop(
            scan.points,
            scan.uv,
            start.faces,
            params["criterion"],
            p=params["p"],
            sliver_guard=params["sliver_guard"],
            tie_tolerance=params["tie_tolerance"],
            sight=curtain_sight(scan),
            curtain_angle=params["curtain_angle"],
        ),
    )
    return Surface(
        vertices=scan.points,
        faces=faces,
        method="lop",
        options={**start.options, **params, "flips": flips, "initial": start.method},
        scan=scan,
        duplicates=start.duplicates,
        timings={**start.timings, "lop": time.perf_counter() - t0},
        line_ids=start.line_ids,
    )


__all__ = ["lop_surface", "OPTIONS"]
