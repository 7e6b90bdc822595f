"""Certified tac-optimal triangulations of small point sets: an exact MILP, and brute force.

Both search all (fine) triangulations of the convex hull of the projected points: every
point is a vertex (it is a scan sample), triangles tile the hull, and the tac norm
(docs/definitions.md: ``tac(v) = |2 pi - sum of 3-D corner angles at v|`` over interior vertices v)
is minimized. Annealing and LOP search the same space heuristically; these functions say
how far from the optimum they stop.

Mixed-integer program (:func:`optimal_surface`)
-----------------------------------------------
Variables: ``x_t`` in {0, 1} for every *empty* triangle t (three non-collinear input points,
no other input point in the closed triangle; computed with exact predicates by
``_core.empty_triangles``). Only empty triangles can occur in a fine triangulation, since a
point inside a triangle or on one of its edges would not be a vertex of it.

Triangulation constraints, the cocircuit ("flow") equations of the universal polytope of
De Loera, Hosten, Santos and Sturmfels, *The polytope of all triangulations of a point
configuration*, Documenta Math. 1 (1996) 103-119 (see also De Loera, Rambau and Santos,
*Triangulations*, Springer 2010, sec. 8.3, where the 0/1 points of this system are shown
to be exactly the triangulations), restricted to empty triangles:

* for every segment e that is an edge of some candidate and lies inside the hull: the
  chosen triangles on its left equal those on its right, ``sum_{t left} x_t =
  sum_{t right} x_t``;
* for every segment on the hull boundary: exactly one chosen triangle uses it,
  ``sum_t x_t = 1``.

A segment is on the hull boundary exactly when candidates lie on only one side of it (an
inner edge has points strictly on both sides, and the nearest point to the line on either
side spans an empty triangle with it). The interior vertices are the points that are not
an end of a boundary segment, i.e. not on the hull boundary (points on a hull edge,
collinear with its ends, are boundary vertices in every triangulation).

Why every 0/1 solution is a triangulation (self-contained, planar case). Let f(q) be the
number of chosen triangles covering a point q off all segments. Moving q across a segment
e at a point on no other segment (two distinct empty segments never overlap, as neither
contains an input point in its relative interior) changes f by (triangles with edge e on
the far side) - (on the near side), which is 0 for inner segments and, crossing into the
hull, 1 - 0 for boundary segments. f = 0 outside, so f = 1 almost everywhere in the hull:
the chosen triangles cover it with disjoint interiors. Two such triangles meet properly,
because a vertex of one on an edge of the other, or overlapping collinear edges, would put
an input point in a closed empty triangle. Every point lies in some closed chosen
triangle and so, by emptiness, is one of its corners. The same argument holds for
fractional x (f = 1 as a density), which makes ``sum_t x_t * planar angle_t(v) = 2 pi``
implied at every interior v; the tac rows below use this. The tests also check every
solution with ``HalfEdgeMesh::validate`` and the hull area.

Objective. With a_t(v) the 3-D corner angle and theta_t(v) the planar one at v,
``s_v = sum_t x_t * (a_t(v) - theta_t(v))`` equals ``sum a - 2 pi`` on every solution and
avoids cancelling against 2 pi. p = 1: minimize ``sum_v y_v`` with ``y_v >= s_v`` and
``y_v >= -s_v``; p = inf: minimize z with ``z >= s_v`` and ``z >= -s_v`` for all v. Other p
would need a nonlinear objective; :func:`brute_force_surface` takes any p >= 1.
Integer-programming approaches to optimal triangulations go back to minimum weight
triangulation (Kyoda, Imai, Takeuchi and Tajima, *A branch-and-cut approach for minimum
weight triangulation*, ISAAC 1997, LNCS 1350); here the solver is HiGHS (Huangfu and
Hall, Math. Prog. Comp. 10 (2018)) through ``scipy.optimize.milp``.

The LP relaxation is weak for tac: it can blend fans with positive and negative angle
defects at a vertex (|s_v| of a blend is below the blend of |s_v|), so proofs need
branching and grow quickly with the number of points (docs/benchmarks/optimum.md).

Optional fan cuts (``strengthen=True``, experimental): the Dantzig-Wolfe reformulation by
vertex stars (Dantzig and Wolfe, Oper. Res. 8 (1960); Desaulniers, Desrosiers and Solomon,
*Column Generation*, Springer 2005) replaces |s_v| by its convex envelope over the fans of
v. Fans are priced exactly, or with a certified lower bound when label fronts are capped,
by ``_core.cheapest_fans`` (a bicriteria label-setting search on the fan DAG around v), the
duals are smoothed (Wentges, Int. Trans. Oper. Res. 4 (1997)), and every vertex's dual
vector gives a valid inequality ``y_v >= -sum_t pi_tv x_t + m_v`` (m_v the pricing lower
bound) that stays in the compact program for branching.

Brute force (:func:`scanmesh.stages.brute_force.brute_force_surface`)
------------------------------------------------------------------
``_core.triangulations`` lists every triangulation by breadth-first search over edge
flips from Delaunay (the flip graph of a planar point set is connected: Lawson 1972), with
a cap on their number. Used to check the MILP on up to about 10 points.
"""

from __future__ import annotations

import math
import time
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from scanmesh import _core
from scanmesh._checks import Option, as_faces, check_options
from scanmesh._interrupt import interruptible
from scanmesh._killable import call_killable
from scanmesh.errors import InvalidMeshError, ParameterError
from scanmesh.formats import ScanPoints
from scanmesh.scan.planar import PlanarScan
from scanmesh.scan.projection import PlaneSpec
from scanmesh.stages.lop import lop_surface
from scanmesh.stages.optimal_program import (
    _assemble,
    _fan_cuts,
    _Geometry,
    _geometry,
    _Instance,
    _instance,
    _with_cutoff,
)
from scanmesh.surface import Surface

if TYPE_CHECKING:
    pass

#: Relative optimality gap at which HiGHS stops and the result counts as proven optimal.
MIP_REL_GAP: float = 1e-6

#: Share of ``time_limit`` the root column generation over fans may use (it stops earlier
#: when it converges); HiGHS gets the rest.
FAN_SHARE: float = 0.5

#: Seconds HiGHS may run past the time it was given before its helper process is killed
#: (its presolve checks the limit only between passes): the whole call then ends within
#: about this much of ``time_limit``.
KILL_AFTER_SECONDS: float = 0.25


#: Most (distinct) points :func:`optimal_surface` accepts: the empty-triangle search is
#: O(n^4) and the program has about 2 n^2 binary variables; proofs already take minutes
#: for a few dozen points (docs/benchmarks/optimum.md).
MAX_OPTIMAL_POINTS: int = 400


#: The optimum's options.
OPTIONS: tuple[Option, ...] = (
    Option(
        "p",
        "float",
        1.0,
        "the tac norm minimized exactly: 1 or math.inf",
        choices=(1.0, math.inf),
        finite=False,
    ),
    Option(
        "time_limit",
        "float",
        60.0,
        "seconds for the fan cuts and HiGHS together (math.inf: none)",
        low=0.0,
        low_open=True,
        finite=False,
    ),
    Option("strengthen", "bool", False, "experimental: fan cuts by column generation first"),
    Option(
        "incumbent",
        "any",
        None,
        "a known triangulation (faces or Surface) whose tac norm cuts the search",
        convert=lambda value: value,  # checked against the hull by _incumbent_faces
    ),
)


def optimal_surface(
    points: ArrayLike | PlanarScan | ScanPoints,
    *,
    p: float = 1,
    plane: PlaneSpec = None,
    time_limit: float = 60.0,
    strengthen: bool = False,
    incumbent: ArrayLike | Surface | None = None,
) -> Surface:
    """The triangulation of the whole convex hull with the smallest tac p-norm, proven.

    Solves the mixed-integer program of the module docstring with HiGHS
    (``scipy.optimize.milp``). Meant for small inputs: proofs take seconds for about 20
    points and can exceed a minute from about 40 (docs/benchmarks/optimum.md).

    Parameters
    ----------
    points : (N, 3) float
        Scan points; any real dtype and memory layout. N <= MAX_OPTIMAL_POINTS after
        merging points that coincide in the plane.
    p : 1 or math.inf
        The tac norm to minimize.
    plane : None, "best-fit", "x", "y", "z" or (3,) float
        Projection plane (see :func:`scanmesh.scan.projection.project`).
    time_limit : float
        Seconds for the fan cuts and HiGHS together (``math.inf``: no limit). Finding the
        empty triangles and LOP's starting fans is not counted.
    strengthen : bool
        Experimental: before branching, run column generation over vertex stars
        (``_fan_cuts``, a Dantzig-Wolfe reformulation) for up to FAN_SHARE of the time
        limit and add the resulting valid cuts. Its bound is far stronger (on a 16-point
        instance the fan LP closes the gap to the optimum from 55 % to 3 %), but without
        warm starts (``scipy.optimize.linprog`` rebuilds each master LP) the columns come
        too slowly to pay off from 20 points on; off by default.
    incumbent : (M, 3) int array or Surface, optional
        A known triangulation of the same hull over the input points (annealing's, say).
        Its tac norm U becomes a cutoff row ``objective <= U (1 - MIP_REL_GAP)``: HiGHS
        searches only strictly better triangulations and prunes every branch whose bound
        reaches U, which is how a heuristic's answer shortens the proof. When none exists
        (the program is infeasible) the incumbent is returned, ``certified`` (optimal
        within MIP_REL_GAP) and ``options["source"] == "incumbent"``.

    Returns
    -------
    Surface
        ``method="optimal"``, faces over the input points covering the convex hull (no
        trimming). ``certified`` is True when HiGHS proved optimality (to a relative gap of
        MIP_REL_GAP); False when the time limit stopped it, with the best triangulation
        known and ``gap`` = (its tac norm - lower bound) / its tac norm.
        ``options`` holds the program's size, the bound and the solver's status;
        ``options["source"]`` says where the faces come from ("highs"; when stopped
        early also "lop" or "delaunay", whichever has the smallest tac norm);
        ``timings`` the seconds per stage. Coincident points are handled as by
        :func:`scanmesh.delaunay` (``Surface.duplicates``, a ``CoincidentPointsWarning``).

    Raises
    ------
    ScanmeshError
        Bad points (shape, non-finite, too few distinct, collinear), p other than 1 or
        inf, a non-positive time limit, or more than MAX_OPTIMAL_POINTS distinct points.
    """
    started = time.perf_counter()  # time_limit counts from here: every stage spends it
    # scipy's optimize is imported here, not at module load: `import scanmesh` stays light.
    from scipy.optimize import Bounds, LinearConstraint, OptimizeResult, milp

    params = check_options(
        OPTIONS,
        {"p": p, "time_limit": time_limit, "strengthen": strengthen, "incumbent": incumbent},
        "optimal_surface",
    )
    p, limit = params["p"], params["time_limit"]
    inst = _instance(points, plane)
    n = len(inst.keep)
    if n > MAX_OPTIMAL_POINTS:
        raise ParameterError(
            f"optimal_surface is exact and exponential: {n} distinct points is more than"
            f" MAX_OPTIMAL_POINTS={MAX_OPTIMAL_POINTS}; use reconstruct(method='anneal')"
        )
    t0 = time.perf_counter()
    # Exactly rescaled: the same orientations, but no overflow at 1e300 or underflow at
    # 1e-300 in the predicates and planar angles.
    uv = np.ascontiguousarray(inst.uv[inst.keep])
    tri = interruptible(n**3, _core.empty_triangles, uv)  # (T, 3) local, counter-clockwise
    geo = _geometry(inst, uv, tri)
    t1 = time.perf_counter()
    cuts = None
    if strengthen and len(geo.interior):
        local = np.full(len(inst.points), -1, dtype=np.int64)
        local[inst.keep] = np.arange(len(inst.keep))
        lop_faces = local[lop_surface(inst.delaunay, p=1.0).faces]
        cuts = _fan_cuts(geo, uv, p, [inst.delaunay_local, lop_faces], started + FAN_SHARE * limit)
    model = _assemble(geo, p, cuts)
    known = None
    if incumbent is not None:
        known_faces = _incumbent_faces(incumbent, inst, tri, geo)
        known = (known_faces, _core_norm(inst.points, known_faces, p))
        model = _with_cutoff(model, known[1] * (1.0 - MIP_REL_GAP))
    t2 = time.perf_counter()
    options: dict[str, object] = {"disp": False, "mip_rel_gap": MIP_REL_GAP}
    if math.isfinite(limit):
        # what is left of the limit after the triangulations, the enumeration, the cuts and
        # the assembly (at least a twentieth of it, for HiGHS to return what it finds)
        options["time_limit"] = max(limit - (t2 - started), 0.05 * limit)
    # HiGHS can run for minutes past its time limit (one presolve pass took 26 s under
    # time_limit=8): in a helper process, killed KILL_AFTER_SECONDS after its own limit or
    # on Ctrl-C
    deadline = None
    if math.isfinite(limit):
        deadline = time.monotonic() + float(options["time_limit"]) + KILL_AFTER_SECONDS
    res = call_killable(
        milp,
        (model.c,),
        {
            "integrality": model.integrality,
            "bounds": Bounds(0.0, model.upper),
            "constraints": LinearConstraint(model.a, model.lower_rows, model.upper_rows),
            "options": options,
        },
        deadline=deadline,
    )
    if res is None:
        # killed: as a run stopped at its time limit with nothing found
        res = OptimizeResult(
            status=1,
            x=None,
            fun=None,
            mip_dual_bound=None,
            mip_node_count=None,
            message=f"HiGHS overran its time limit and was stopped {KILL_AFTER_SECONDS:g} s"
            " after it",
        )
    t3 = time.perf_counter()
    proven_by_cutoff = known is not None and res.status == 2
    if res.status not in (0, 1) and not proven_by_cutoff:
        raise RuntimeError(
            f"HiGHS could not solve the triangulation program ({res.message}); every point"
            " set has a triangulation, so this is a bug: please report it with the points"
        )
    found = res.x is not None
    certified = bool(res.status == 0) or proven_by_cutoff
    candidates: list[tuple[str, np.ndarray]] = []
    if known is not None:
        candidates.append(("incumbent", known[0]))
    if found:
        chosen = res.x[: len(tri)] > 0.5
        # 0/1 and the integer rows hold exactly: by the theorem, a triangulation.
        residual = geo.flow @ chosen.astype(np.int64) - geo.flow_rhs
        if np.any(residual != 0):
            raise RuntimeError(
                f"HiGHS returned a solution that breaks {int(np.count_nonzero(residual))}"
                " triangulation equations after rounding; please report it with the points"
            )
        candidates.append(("highs", inst.keep[tri[chosen]]))
    if not certified:
        # Stopped early: return the best triangulation known, HiGHS's or a local optimum.
        candidates.append(("lop", lop_surface(inst.delaunay, p=1.0).faces))
        candidates.append(("delaunay", inst.delaunay.faces))
    scored = [
        (_core_norm(inst.points, faces, p), k, name) for k, (name, faces) in enumerate(candidates)
    ]
    # Ties go to the solver's triangulation (listed after the incumbent, so compare it first).
    value, best, source = min(scored, key=lambda v: (v[0], v[2] != "highs", v[1]))
    bound = res.mip_dual_bound if res.mip_dual_bound is not None else 0.0
    bound = max(0.0, float(bound)) if math.isfinite(bound) else 0.0
    if known is not None:
        # Every triangulation better than the cutoff was searched for: the cutoff bounds.
        bound = known[1] * (1.0 - MIP_REL_GAP) if proven_by_cutoff else min(bound, known[1])
    t4 = time.perf_counter()
    faces = np.ascontiguousarray(candidates[best][1], dtype=np.int64)
    # A fallback start (Delaunay, LOP) may have lost a collinear hull point to trimming's
    # sliver peeling: such points are listed, as every method accounts for each point.
    accounted = np.zeros(len(inst.points), dtype=bool)
    accounted[faces.ravel()] = True
    accounted[inst.duplicates[:, 0]] = True
    surface = Surface(
        vertices=inst.points,
        faces=faces,
        method="optimal",
        scan=inst.scan,
        duplicates=inst.duplicates,
        certified=certified,
        gap=0.0 if value <= bound or value == 0.0 else (value - bound) / value,
        options={
            "p": p,
            "plane": inst.scan.plane,
            "time_limit": limit,
            "max_edge": math.inf,
            "candidate_triangles": int(len(tri)),
            "interior_vertices": int(len(geo.interior)),
            "equations": int(geo.flow.shape[0]),
            "fan_cuts": 0 if cuts is None else int(len(cuts.rhs)),
            "incumbent_value": None if known is None else known[1],
            **({} if cuts is None else cuts.info),
            "lower_bound": bound,
            "solver_objective": None if res.fun is None else float(res.fun),
            "nodes": res.mip_node_count,
            "status": res.message,
            "solution_found": found,
            "source": source,
            "trimmed": np.flatnonzero(~accounted).astype(np.int64),
        },
        timings={
            "project_delaunay": inst.seconds,
            "empty_triangles": t1 - t0,
            "fan_cuts": t2 - t1,
            "solve": t3 - t2,
            "compare": t4 - t3,
        },
    )
    if certified:
        # Proven within MIP_REL_GAP (and HiGHS's tolerances): report no more than that.
        surface.gap = min(surface.gap, MIP_REL_GAP)
    return surface


def _incumbent_faces(
    incumbent: ArrayLike | Surface, inst: _Instance, tri: np.ndarray, geo: _Geometry
) -> np.ndarray:
    """The incumbent's faces as (M, 3) int64 input indices, checked to be a triangulation
    of the hull: every face an empty candidate triangle and the flow equations met (the
    module docstring's theorem), so a wrong incumbent cannot cut the optimum off."""
    faces = incumbent.faces if isinstance(incumbent, Surface) else incumbent
    arr = as_faces(faces, len(inst.points), "incumbent faces")
    local = np.full(len(inst.points), -1, dtype=np.int64)
    local[inst.keep] = np.arange(len(inst.keep))
    index = {tuple(sorted(t)): k for k, t in enumerate(tri.tolist())}
    chosen = np.zeros(len(tri), dtype=np.int64)
    for row, face in enumerate(local[arr].tolist()):
        k = index.get(tuple(sorted(face)), -1)
        if k < 0 or chosen[k]:
            raise InvalidMeshError(
                f"incumbent face {row} {arr[row].tolist()} is not an empty triangle of"
                " distinct hull points (or repeats one)"
            )
        chosen[k] = 1
    if np.any(geo.flow @ chosen != geo.flow_rhs):
        raise InvalidMeshError(
            "incumbent faces do not triangulate the convex hull of the points (a gap or an"
            " overlap); pass a Surface built with max_edge=math.inf"
        )
    return np.ascontiguousarray(arr, dtype=np.int64)


def _core_norm(points: np.ndarray, faces: np.ndarray, p: float) -> float:
    """tac p-norm of ``faces`` over ``points`` as Surface.quality measures it."""
    tac, _ = _core.mesh_quality(points, np.ascontiguousarray(faces, dtype=np.int64))
    return _core.tac_norm(tac, p)


__all__ = ["optimal_surface", "MIP_REL_GAP", "MAX_OPTIMAL_POINTS"]
