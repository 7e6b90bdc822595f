"""Certified tac-optimal triangulations of small point sets: an exact MILP, and brute force.

Both search all (fine) triangulations of the convex hull of the projected points: every
point is a vertex (it is a scan sample), triangles tile the hull, and the tac norm
(DESIGN.md: ``tac(v) = |2 pi - sum of 3-D corner angles at v|`` over interior vertices v)
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
branching and grow quickly with the number of points (BENCHMARKS.md).

Optional fan cuts (``strengthen=True``, experimental): the Dantzig-Wolfe reformulation by
vertex stars (Dantzig and Wolfe, Oper. Res. 8 (1960); Desaulniers, Desrosiers and Solomon,
*Column Generation*, Springer 2005) replaces |s_v| by its convex envelope over the fans of
v. Fans are priced exactly, or with a certified lower bound when label fronts are capped,
by ``_core.cheapest_fans`` (a bicriteria label-setting search on the fan DAG around v), the
duals are smoothed (Wentges, Int. Trans. Oper. Res. 4 (1997)), and every vertex's dual
vector gives a valid inequality ``y_v >= -sum_t pi_tv x_t + m_v`` (m_v the pricing lower
bound) that stays in the compact program for branching.

Brute force (:func:`brute_force_surface`)
-----------------------------------------
``_core.triangulations`` lists every triangulation by breadth-first search over edge
flips from Delaunay (the flip graph of a planar point set is connected: Lawson 1972), with
a cap on their number. Used to check the MILP on up to about 10 points.
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from scanmesh import _core
from scanmesh._checks import Option, as_faces, check_options, power_of_two_unit
from scanmesh.delaunay import delaunay
from scanmesh.errors import InvalidMeshError, ParameterError
from scanmesh.projection import PlaneSpec
from scanmesh.scan import PlanarScan, as_scan
from scanmesh.surface import Surface

if TYPE_CHECKING:
    import scipy.sparse as sp

#: Relative optimality gap at which HiGHS stops and the result counts as proven optimal.
MIP_REL_GAP: float = 1e-6

#: Share of ``time_limit`` the root column generation over fans may use (it stops earlier
#: when it converges); HiGHS gets the rest.
FAN_SHARE: float = 0.5

#: Weight of the best duals so far in the prices of the fan column generation (Wentges
#: smoothing, 0 = plain column generation).
SMOOTHING: float = 0.7

#: Default cap on the number of triangulations :func:`brute_force_surface` enumerates.
MAX_TRIANGULATIONS: int = 200_000

#: Most (distinct) points :func:`optimal_surface` accepts: the empty-triangle search is
#: O(n^4) and the program has about 2 n^2 binary variables; proofs already take minutes
#: for a few dozen points (BENCHMARKS.md).
MAX_OPTIMAL_POINTS: int = 400


@dataclass(frozen=True)
class _Instance:
    """One input, projected, with coincident points merged (delaunay()'s handling)."""

    #: the checked, projected input
    scan: PlanarScan
    #: (N, 2) float64 its planar coordinates, scaled by a power of two into [-1, 1]
    uv: np.ndarray
    #: (n,) int64 input index of each distinct point (the local index is the position)
    keep: np.ndarray
    #: (K, 2) int64 (unused point, the coincident point standing for it)
    duplicates: np.ndarray
    #: (M, 3) int64 Delaunay triangles of the hull, local indices, counter-clockwise
    delaunay_local: np.ndarray
    #: the Delaunay triangulation of the hull itself (input indices)
    delaunay: Surface
    #: seconds spent projecting and triangulating
    seconds: float


    @property
    def points(self) -> np.ndarray:
        """(N, 3) float64 the input points."""
        return self.scan.points


def _instance(points: ArrayLike | PlanarScan, plane: PlaneSpec) -> _Instance:
    t0 = time.perf_counter()
    scan = as_scan(points, plane=plane)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        base = delaunay(scan, max_edge=math.inf)
    for w in caught:  # re-issued so that they point at the caller's line
        warnings.warn(w.message, w.category, stacklevel=4)
    # Scaled by a power of two (exact: every orientation sign kept) so that |uv| <= 1: the
    # exact predicates and planar angles overflow at 1e300 and underflow at 1e-300.
    uv, _ = power_of_two_unit(scan.uv)
    used = np.ones(len(scan.points), dtype=bool)
    used[base.duplicates[:, 0]] = False
    keep = np.flatnonzero(used)
    local = np.full(len(scan.points), -1, dtype=np.int64)
    local[keep] = np.arange(len(keep))
    return _Instance(
        scan=scan,
        uv=uv,
        keep=keep,
        duplicates=base.duplicates,
        delaunay_local=local[base.faces],
        delaunay=base,
        seconds=time.perf_counter() - t0,
    )


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


def _unit(points: np.ndarray) -> np.ndarray:
    """(N, 3) points mapped into [-1, 1]^3 as the core's Normalizer does (angles unchanged)."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    half = float((hi * 0.5 - lo * 0.5).max())
    centred = points - (lo * 0.5 + hi * 0.5)
    return centred / half if half > 0 else centred


def _corner_angles(xyz: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """(..., 3) corner angles (radians) of triangles ``tri`` (..., 3) over points (N, 2 or 3).

    Column k is the angle at ``tri[..., k]``, in the atan2 form of DESIGN.md.
    """
    if xyz.shape[1] == 2:
        xyz = np.column_stack([xyz, np.zeros(len(xyz))])
    out = np.empty(tri.shape, dtype=np.float64)
    for k in range(3):
        p = xyz[tri[..., k]]
        u = xyz[tri[..., (k + 1) % 3]] - p
        v = xyz[tri[..., (k + 2) % 3]] - p
        out[..., k] = np.arctan2(
            np.linalg.norm(np.cross(u, v), axis=-1), np.einsum("...i,...i->...", u, v)
        )
    return out


def _interior_mask(n: int, triangles: np.ndarray) -> np.ndarray:
    """(n,) bool: vertices on no boundary edge of one triangulation (M, 3) of the hull."""
    directed = np.stack([triangles, np.roll(triangles, -1, axis=1)], axis=-1).reshape(-1, 2)
    keys = directed.min(axis=1) * n + directed.max(axis=1)
    unique, counts = np.unique(keys, return_counts=True)
    boundary = unique[counts == 1]
    interior = np.ones(n, dtype=bool)
    interior[boundary // n] = False
    interior[boundary % n] = False
    return interior


def optimal_surface(
    points: ArrayLike | PlanarScan,
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
    points and can exceed a minute from about 40 (BENCHMARKS.md).

    Parameters
    ----------
    points : (N, 3) float
        Scan points; any real dtype and memory layout. N <= MAX_OPTIMAL_POINTS after
        merging points that coincide in the plane.
    p : 1 or math.inf
        The tac norm to minimize.
    plane : None, "best-fit", "x", "y", "z" or (3,) float
        Projection plane (see :func:`scanmesh.projection.project`).
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
    # scipy's optimize is imported here, not at module load: `import scanmesh` stays light.
    from scipy.optimize import Bounds, LinearConstraint, milp

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
    tri = _core.empty_triangles(uv)  # (T, 3) local indices, counter-clockwise
    geo = _geometry(inst, uv, tri)
    t1 = time.perf_counter()
    cuts = None
    if strengthen and len(geo.interior):
        from scanmesh.lop import lop_surface

        local = np.full(len(inst.points), -1, dtype=np.int64)
        local[inst.keep] = np.arange(len(inst.keep))
        lop_faces = local[lop_surface(inst.delaunay, p=1.0).faces]
        cuts = _fan_cuts(geo, uv, p, [inst.delaunay_local, lop_faces], t1 + FAN_SHARE * limit)
    model = _assemble(geo, p, cuts)
    known = None
    if incumbent is not None:
        known_faces = _incumbent_faces(incumbent, inst, tri, geo)
        known = (known_faces, _core_norm(inst.points, known_faces, p))
        model = _with_cutoff(model, known[1] * (1.0 - MIP_REL_GAP))
    t2 = time.perf_counter()
    options: dict[str, object] = {"disp": False, "mip_rel_gap": MIP_REL_GAP}
    if math.isfinite(limit):
        options["time_limit"] = max(limit - (t2 - t1), 0.05 * limit)
    res = milp(
        model.c,
        integrality=model.integrality,
        bounds=Bounds(0.0, model.upper),
        constraints=LinearConstraint(model.a, model.lower_rows, model.upper_rows),
        options=options,
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
        from scanmesh.lop import lop_surface

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


def _with_cutoff(model: _Program, cutoff: float) -> _Program:
    """The program with one more row, objective <= cutoff."""
    import scipy.sparse as sp

    return _Program(
        model.c,
        model.integrality,
        model.upper,
        sp.vstack([model.a, sp.csr_array(model.c[None, :])], format="csr"),
        np.r_[model.lower_rows, -np.inf],
        np.r_[model.upper_rows, cutoff],
    )


def _core_norm(points: np.ndarray, faces: np.ndarray, p: float) -> float:
    """tac p-norm of ``faces`` over ``points`` as Surface.quality measures it."""
    tac, _ = _core.mesh_quality(points, np.ascontiguousarray(faces, dtype=np.int64))
    return _core.tac_norm(tac, p)


@dataclass(frozen=True)
class _Geometry:
    """Everything the program needs about one instance's candidate triangles."""

    #: (T, 3) int64 candidate (empty) triangles, local indices, counter-clockwise
    tri: np.ndarray
    #: (E, T) triangulation equations (integer coefficients) and (E,) their right sides
    flow: sp.csr_array
    flow_rhs: np.ndarray
    #: (I,) int64 local indices of the interior vertices
    interior: np.ndarray
    #: (n,) int64 row of each vertex among the interior ones, -1 on the hull
    row_of: np.ndarray
    #: (T, 3) float64 3-D minus planar corner angle (radians)
    dev: np.ndarray
    #: (I, T) s_v = sum_t x_t dev_t(v): the negative angle defect at interior vertex v
    s: sp.csr_array


def _geometry(inst: _Instance, uv: np.ndarray, tri: np.ndarray) -> _Geometry:
    """Triangulation equations (module docstring) and the tac data of the candidates."""
    import scipy.sparse as sp

    n, t_count = len(uv), len(tri)
    # Edges: triangle t lies left of its directed edge (a -> b); +1 when a < b.
    a_end = tri.reshape(-1)
    b_end = np.roll(tri, -1, axis=1).reshape(-1)
    owner = np.repeat(np.arange(t_count), 3)
    sign = np.where(a_end < b_end, 1, -1)
    keys = np.minimum(a_end, b_end) * n + np.maximum(a_end, b_end)
    edge_keys, edge_of = np.unique(keys, return_inverse=True)
    has_left = np.zeros(len(edge_keys), dtype=bool)
    has_right = np.zeros(len(edge_keys), dtype=bool)
    has_left[edge_of[sign > 0]] = True
    has_right[edge_of[sign < 0]] = True
    inner = has_left & has_right
    # Inner segments: sum(left) - sum(right) = 0. Hull segments: sum = 1 (one side only).
    coef = np.where(inner[edge_of], sign, 1)
    flow = sp.csr_array((coef, (edge_of, owner)), shape=(len(edge_keys), t_count))
    flow_rhs = np.where(inner, 0, 1).astype(np.int64)
    on_hull = np.zeros(n, dtype=bool)
    hull_keys = edge_keys[~inner]
    on_hull[hull_keys // n] = True
    on_hull[hull_keys % n] = True
    interior = np.flatnonzero(~on_hull)
    row_of = np.full(n, -1, dtype=np.int64)
    row_of[interior] = np.arange(len(interior))
    dev = _corner_angles(_unit(inst.points), inst.keep[tri]) - _corner_angles(uv, tri)
    corner_rows = row_of[tri].reshape(-1)
    at = corner_rows >= 0
    s = sp.csr_array(
        (dev.reshape(-1)[at], (corner_rows[at], owner[at])), shape=(len(interior), t_count)
    )
    return _Geometry(tri, flow, flow_rhs, interior, row_of, dev, s)


@dataclass(frozen=True)
class _Cuts:
    """Fan cuts ``y_v + sum_t coef_t x_t >= rhs`` (one row per cut) and how they came about."""

    #: (K, T) coefficients on x
    coef: sp.csr_array
    #: (K,) right-hand sides
    rhs: np.ndarray
    #: (K,) interior row (index into _Geometry.interior) of each cut's y_v
    vertex: np.ndarray
    #: Dantzig-Wolfe (fan) bound reached, the plain LP bound, and the loop's statistics
    info: dict


def _fan_cuts(
    geo: _Geometry, uv: np.ndarray, p: float, starts: list[np.ndarray], deadline: float
) -> _Cuts | None:
    """Column generation over fans at the root, turned into valid cuts on y_v = tac(v).

    Master LP: x in the triangulation polytope, and per interior vertex v a convex
    combination of fans F (stars of v, lambda_vF >= 0, sum_F lambda_vF = 1) that reproduces x
    at v; objective sum_v sum_F |s_F| lambda_vF (p = 1) or max_v of it (p = inf). This is the
    Dantzig-Wolfe reformulation of the tac program by vertex stars; its bound convexifies
    |s_v| per vertex instead of taking |s_v| of a blend of fans. Fans are priced exactly by
    ``_core.cheapest_fans``. With duals pi_tv (linking rows) and weight w_v, every fan F
    satisfies ``w_v |s_F| >= -sum_{t in F} pi_tv + m_v`` where m_v is the exact pricing
    minimum, so ``y_v >= -sum_t (pi_tv / w_v) x_t + m_v / w_v`` holds for every
    triangulation: a valid cut, whatever the state of convergence. Stops when no fan has
    negative reduced cost or at ``deadline`` (perf_counter seconds). None when no start is
    a triangulation of the enumerated triangles.
    """
    import scipy.sparse as sp
    from scipy.optimize import linprog

    tri, n_i = geo.tri, len(geo.interior)
    t_count, e_count = len(tri), geo.flow.shape[0]
    # Interior corners (triangle, k): one linking row each.
    ct, ck = np.nonzero(geo.row_of[tri] >= 0)
    corner_id = np.full(tri.shape, -1, dtype=np.int64)
    corner_id[ct, ck] = np.arange(len(ct))
    c_count = len(ct)
    index = {tuple(t): i for i, t in enumerate(tri.tolist())}
    columns: list[tuple[int, np.ndarray]] = []  # (interior row, fan triangle indices)
    seen: set[tuple[int, tuple[int, ...]]] = set()

    def add(row: int, fan: np.ndarray) -> bool:
        key = (row, tuple(sorted(fan.tolist())))
        if key in seen:
            return False
        seen.add(key)
        columns.append((row, np.asarray(fan, dtype=np.int64)))
        return True

    for faces in starts:
        found = []
        for t in faces.tolist():
            k = t.index(min(t))
            found.append(index.get(tuple(t[k:] + t[:k])))
        chosen = np.zeros(t_count, dtype=np.int64)
        chosen[[i for i in found if i is not None]] = 1
        if None in found or np.any(geo.flow @ chosen != geo.flow_rhs):
            # A face the enumeration does not list, or a gap or overlap: the start is not a
            # triangulation in these planar coordinates (though it is where the core
            # triangulated), so its fans would make the master LP infeasible.
            continue
        ids = np.asarray(found)
        for row, v in enumerate(geo.interior):
            add(row, ids[np.any(tri[ids] == v, axis=1)])
    if not columns:
        return None  # no usable start: the program goes without fan cuts
    x_link = sp.csr_array((np.ones(c_count), (np.arange(c_count), ct)), shape=(c_count, t_count))
    flow_x = geo.flow.astype(np.float64)
    weights = np.ones(n_i)
    best_bound = -math.inf
    best_duals = center = None
    iterations = 0
    while True:
        iterations += 1
        k_count = len(columns)
        rows, cols, fan_s = [], [], np.empty(k_count)
        conv_rows = np.empty(k_count, dtype=np.int64)
        for j, (row, fan) in enumerate(columns):
            v = geo.interior[row]
            kv = np.argmax(tri[fan] == v, axis=1)
            rows.append(corner_id[fan, kv])
            cols.append(np.full(len(fan), j))
            fan_s[j] = geo.dev[fan, kv].sum()
            conv_rows[j] = row
        lam_link = sp.csr_array(
            (-np.ones(sum(map(len, rows))), (np.concatenate(rows), np.concatenate(cols))),
            shape=(c_count, k_count),
        )
        lam_conv = sp.csr_array(
            (np.ones(k_count), (conv_rows, np.arange(k_count))), shape=(n_i, k_count)
        )
        extra = 1 if math.isinf(p) else 0  # z for p = inf
        a_eq = sp.vstack(
            [
                sp.hstack([flow_x, sp.csr_array((e_count, k_count + extra))]),
                sp.hstack([x_link, lam_link, sp.csr_array((c_count, extra))]),
                sp.hstack([sp.csr_array((n_i, t_count)), lam_conv, sp.csr_array((n_i, extra))]),
            ],
            format="csr",
        )
        b_eq = np.concatenate([geo.flow_rhs, np.zeros(c_count), np.ones(n_i)])
        bounds = np.column_stack(
            [
                np.zeros(t_count + k_count + extra),
                np.r_[np.ones(t_count), np.full(k_count + extra, np.inf)],
            ]
        )
        if extra:
            cost = np.r_[np.zeros(t_count + k_count), 1.0]
            a_ub = sp.hstack(
                [
                    sp.csr_array((n_i, t_count)),
                    sp.csr_array(
                        (np.abs(fan_s), (conv_rows, np.arange(k_count))), shape=(n_i, k_count)
                    ),
                    sp.csr_array(-np.ones((n_i, 1))),
                ],
                format="csr",
            )
            res = linprog(
                cost,
                A_ub=a_ub,
                b_ub=np.zeros(n_i),
                A_eq=a_eq,
                b_eq=b_eq,
                bounds=bounds,
                method="highs",
            )
        else:
            cost = np.r_[np.zeros(t_count), np.abs(fan_s)]
            res = linprog(cost, A_eq=a_eq, b_eq=b_eq, bounds=bounds, method="highs")
        if res.status != 0:
            raise RuntimeError(f"fan master LP failed ({res.message}); please report it")
        duals = res.eqlin.marginals
        link, conv = duals[e_count : e_count + c_count], duals[e_count + c_count :]
        if extra:
            weights = np.maximum(0.0, -res.ineqlin.marginals)
        tol = 1e-9 * max(1.0, abs(res.fun))
        added = 0
        # Price at the LP's duals (for the bound and columns), and at duals smoothed
        # towards the best so far (Wentges), which damps the zig-zag of plain column
        # generation and yields further columns.
        trials = [(link, conv, weights)]
        if center is not None:
            a = SMOOTHING
            trials.append(
                tuple(a * c + (1 - a) * x for c, x in zip(center, trials[0], strict=True))
            )
        for k, (lk, cv, wt) in enumerate(trials):
            price = np.zeros(tri.shape)
            price[ct, ck] = lk
            lows, owner, _, flat, offsets = _core.cheapest_fans(
                uv, tri, geo.dev, price, geo.interior, wt
            )
            if k == 0:
                # Lagrangian bound: the master value plus each vertex's least reduced cost.
                bound = res.fun + float(np.minimum(lows - cv, 0.0).sum())
                if bound > best_bound:
                    best_bound, best_duals, center = bound, (lk, lows, wt), (lk, cv, wt)
            for f, row in enumerate(owner.tolist()):
                fan = flat[offsets[f] : offsets[f + 1]]
                # Reduced cost of this real fan at the LP's own duals.
                kv = np.argmax(tri[fan] == geo.interior[row], axis=1)
                rc = weights[row] * abs(geo.dev[fan, kv].sum()) + link[corner_id[fan, kv]].sum()
                if rc - conv[row] < -tol:
                    added += add(row, fan)
        if added == 0 or time.perf_counter() > deadline:
            break
    link, lows, weights = best_duals
    keep = weights > 1e-12
    coef_rows, coef_cols, coef_vals = [], [], []
    corner_row = geo.row_of[tri[ct, ck]]
    for r in np.flatnonzero(keep):
        corners = np.flatnonzero(corner_row == r)
        coef_rows.append(np.full(len(corners), len(coef_rows)))
        coef_cols.append(ct[corners])
        coef_vals.append(link[corners] / weights[r])
    k = len(coef_rows)
    coef = sp.csr_array(
        (np.concatenate(coef_vals), (np.concatenate(coef_rows), np.concatenate(coef_cols)))
        if k
        else (np.empty(0), (np.empty(0, int), np.empty(0, int))),
        shape=(k, t_count),
    )
    rhs = lows[keep] / weights[keep]
    # A hair of slack so rounding in the angles can never cut off a triangulation.
    rhs = rhs - 1e-9 * (1.0 + np.abs(rhs))
    info = {
        "fan_bound": max(best_bound, 0.0),
        "fan_iterations": iterations,
        "fan_columns": len(columns),
        "fan_converged": added == 0,
    }
    return _Cuts(coef, rhs, np.flatnonzero(keep), info)


@dataclass(frozen=True)
class _Program:
    c: np.ndarray
    integrality: np.ndarray
    upper: np.ndarray
    a: sp.csr_array
    lower_rows: np.ndarray
    upper_rows: np.ndarray


def _assemble(geo: _Geometry, p: float, cuts: _Cuts | None) -> _Program:
    """The MILP over x (T binary), y (I, y_v >= |s_v|) and, for p = inf, z >= every y_v."""
    import scipy.sparse as sp

    t_count, n_i = len(geo.tri), len(geo.interior)
    inf_norm = math.isinf(p)
    n_cols = t_count + n_i + int(inf_norm)
    eye = sp.identity(n_i, format="csr")
    blocks = [
        (
            sp.hstack([geo.flow, sp.csr_array((geo.flow.shape[0], n_cols - t_count))]),
            geo.flow_rhs,
            geo.flow_rhs,
        ),
        (sp.hstack([geo.s, eye, sp.csr_array((n_i, int(inf_norm)))]), 0.0, np.inf),  # y + s >= 0
        (sp.hstack([-geo.s, eye, sp.csr_array((n_i, int(inf_norm)))]), 0.0, np.inf),  # y - s >= 0
    ]
    if inf_norm:
        blocks.append(
            (
                sp.hstack([sp.csr_array((n_i, t_count)), -eye, sp.csr_array(np.ones((n_i, 1)))]),
                0.0,
                np.inf,
            )
        )
    if cuts is not None and len(cuts.rhs):
        k = len(cuts.rhs)
        pick = sp.csr_array((np.ones(k), (np.arange(k), cuts.vertex)), shape=(k, n_i))
        blocks.append(
            (sp.hstack([cuts.coef, pick, sp.csr_array((k, int(inf_norm)))]), cuts.rhs, np.inf)
        )
    a = sp.vstack([b[0] for b in blocks], format="csr")
    lower = np.concatenate(
        [np.broadcast_to(np.asarray(b[1], float), (b[0].shape[0],)) for b in blocks]
    )
    upper = np.concatenate(
        [np.broadcast_to(np.asarray(b[2], float), (b[0].shape[0],)) for b in blocks]
    )
    if inf_norm:
        c = np.r_[np.zeros(t_count + n_i), 1.0]
    else:
        c = np.r_[np.zeros(t_count), np.ones(n_i)]
    integrality = np.r_[np.ones(t_count), np.zeros(n_cols - t_count)]
    bound = np.r_[np.ones(t_count), np.full(n_cols - t_count, np.inf)]
    return _Program(c, integrality, bound, a, lower, upper)


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


__all__ = [
    "optimal_surface",
    "brute_force_surface",
    "triangulations",
    "MIP_REL_GAP",
    "MAX_TRIANGULATIONS",
    "MAX_OPTIMAL_POINTS",
]
