"""The tac optimum by enumeration: every triangulation of a small point set, and the best
one under any tac norm (a check of :func:`scanmesh.stages.optimal.optimal_surface`)."""

from __future__ import annotations

import math
import time
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from scanmesh import _core
from scanmesh._checks import Option
from scanmesh.scan.projection import PlaneSpec
from scanmesh.stages.optimal_program import (
    _corner_angles,
    _Instance,
    _instance,
    _interior_mask,
    _unit,
)
from scanmesh.surface import Surface

if TYPE_CHECKING:
    pass


#: Default cap on the number of triangulations :func:`brute_force_surface` enumerates.
MAX_TRIANGULATIONS: int = 200_000


#: The most triangulations one enumeration may hold (each is a (M, 3) array).
MAX_ENUMERATED: int = 10**8


_MAX_COUNT = Option(
    "max_count",
    "int",
    MAX_TRIANGULATIONS,
    "most triangulations to list",
    low=1,
    high=MAX_ENUMERATED,
)


#: brute_force_surface's p: any norm >= 1.
_ANY_P = Option("p", "float", 1.0, "the tac norm", low=1.0, finite=False)


def triangulations(
    points: ArrayLike, *, plane: PlaneSpec = None, max_count: int = MAX_TRIANGULATIONS
) -> np.ndarray:
    """Every triangulation of the convex hull of the projected points, all points used.

    Parameters
    ----------
    points : (N, 3) float
        A few points (the count grows exponentially: Catalan(N - 2) in convex position).
    plane : None, "best-fit", "x", "y", "z" or (3,) float
        Projection plane.
    max_count : int
        Raise ParameterError rather than enumerate more than this many.

    Returns
    -------
    (K, M, 3) int64
        K triangulations of M counter-clockwise triangles each, as input indices (points
        coinciding in the plane with an earlier one are left out, as in delaunay()).
    """
    inst = _instance(points, plane)
    return inst.keep[_all_local(inst, max_count)]


def _all_local(inst: _Instance, max_count: int, name: str = "max_count") -> np.ndarray:
    max_count = _MAX_COUNT.check(max_count, name)
    uv = np.ascontiguousarray(inst.uv[inst.keep])
    return _core.triangulations(uv, inst.delaunay_local, int(max_count))


def brute_force_surface(
    points: ArrayLike,
    *,
    p: float = 1,
    plane: PlaneSpec = None,
    max_triangulations: int = MAX_TRIANGULATIONS,
) -> Surface:
    """The tac-optimal triangulation of the convex hull by trying every triangulation.

    Parameters
    ----------
    points : (N, 3) float
        A few points (about 10; the number of triangulations grows exponentially).
    p : float
        Any tac norm, p >= 1 or ``math.inf``.
    plane : None, "best-fit", "x", "y", "z" or (3,) float
        Projection plane.
    max_triangulations : int
        Raise ParameterError rather than enumerate more than this many.

    Returns
    -------
    Surface
        ``method="brute-force"``, ``certified=True``, ``gap=0.0``; the first of the best
        (ties: in breadth-first order from Delaunay). ``options["n_triangulations"]`` is
        how many were compared.
    """
    p = _ANY_P.check(p)
    inst = _instance(points, plane)
    t0 = time.perf_counter()
    every = _all_local(inst, max_triangulations, "max_triangulations")  # (K, M, 3) local indices
    t1 = time.perf_counter()
    n = len(inst.keep)
    angles = _corner_angles(_unit(inst.points), inst.keep[every])  # (K, M, 3)
    flat = (np.arange(len(every))[:, None, None] * n + every).reshape(-1)
    sums = np.bincount(flat, weights=angles.reshape(-1), minlength=len(every) * n)
    interior = _interior_mask(n, every[0])
    tac = np.abs(2 * np.pi - sums.reshape(len(every), n)[:, interior])  # (K, I)
    if tac.shape[1] == 0:
        score = np.zeros(len(every))
    elif math.isinf(p):
        score = tac.max(axis=1)
    else:
        score = (tac**p).sum(axis=1)
    best = int(np.argmin(score))
    t2 = time.perf_counter()
    return Surface(
        vertices=inst.points,
        faces=np.ascontiguousarray(inst.keep[every[best]], dtype=np.int64),
        method="brute-force",
        options={
            "p": p,
            "plane": inst.scan.plane,
            "max_edge": math.inf,
            "n_triangulations": int(len(every)),
            "max_triangulations": int(max_triangulations),
        },
        scan=inst.scan,
        duplicates=inst.duplicates,
        timings={"project_delaunay": inst.seconds, "enumerate": t1 - t0, "score": t2 - t1},
        certified=True,
        gap=0.0,
    )


__all__ = ["brute_force_surface", "triangulations", "MAX_TRIANGULATIONS"]
