"""The tac optimum's integer program: the instance (points checked and projected once),
the candidate triangles' geometry, the fan cuts found by column generation, and the
assembled MILP that HiGHS solves (see :mod:`scanmesh.stages.optimal`)."""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass
from functools import partial
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from scanmesh import _core
from scanmesh._checks import power_of_two_unit
from scanmesh._interrupt import UNBOUNDED, interruptible
from scanmesh.formats import ScanPoints
from scanmesh.scan.planar import PlanarScan, as_scan
from scanmesh.scan.projection import PlaneSpec
from scanmesh.stages.delaunay import delaunay
from scanmesh.surface import Surface

if TYPE_CHECKING:
    import scipy.sparse as sp  # scipy loads only for the optimum: `import scanmesh` stays light


#: Weight of the best duals so far in the prices of the fan column generation (Wentges
#: smoothing, 0 = plain column generation).
SMOOTHING: float = 0.7


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


def _instance(points: ArrayLike | PlanarScan | ScanPoints, plane: PlaneSpec) -> _Instance:
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


def _unit(points: np.ndarray) -> np.ndarray:
    """(N, 3) points mapped into [-1, 1]^3 as the core's Normalizer does (angles unchanged)."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    half = float((hi * 0.5 - lo * 0.5).max())
    centred = points - (lo * 0.5 + hi * 0.5)
    return centred / half if half > 0 else centred


def _corner_angles(xyz: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """(..., 3) corner angles (radians) of triangles ``tri`` (..., 3) over points (N, 2 or 3).

    Column k is the angle at ``tri[..., k]``, in the atan2 form of docs/definitions.md.
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


def _with_cutoff(model: _Program, cutoff: float) -> _Program:
    """The program with one more row, objective <= cutoff."""
    import scipy.sparse as sp  # scipy loads only for the optimum: `import scanmesh` stays light

    return _Program(
        model.c,
        model.integrality,
        model.upper,
        sp.vstack([model.a, sp.csr_array(model.c[None, :])], format="csr"),
        np.r_[model.lower_rows, -np.inf],
        np.r_[model.upper_rows, cutoff],
    )


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
    import scipy.sparse as sp  # scipy loads only for the optimum: `import scanmesh` stays light

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


#: Least time limit (seconds) a HiGHS call is given, however little of ``time_limit`` is
#: left: it must be able to return what it has.
MIN_SOLVER_SECONDS: float = 0.01


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
    import scipy.sparse as sp  # scipy loads only for the optimum: `import scanmesh` stays light
    from scipy.optimize import linprog  # the HiGHS LP, loaded with the optimum only

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
            master = {"A_ub": a_ub, "b_ub": np.zeros(n_i)}
        else:
            cost = np.r_[np.zeros(t_count), np.abs(fan_s)]
            master = {}
        # HiGHS in a worker, so that Ctrl-C is not kept waiting by a slow master LP; given
        # the time left, so that the column generation keeps to its share of time_limit
        left = deadline - time.perf_counter()
        if left <= 0.0 and best_duals is not None:
            break
        res = interruptible(
            UNBOUNDED,
            partial(
                linprog,
                cost,
                A_eq=a_eq,
                b_eq=b_eq,
                bounds=bounds,
                method="highs",
                options={"time_limit": max(left, MIN_SOLVER_SECONDS)},
                **master,
            ),
        )
        if res.status == 1:  # stopped at the time limit: the cuts of the duals so far
            if best_duals is None:
                return None
            break
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
            fans = _core.cheapest_fans(uv, tri, geo.dev, price, geo.interior, wt)
            lows, owner, flat, offsets = fans.lower_bounds, fans.owner, fans.fans, fans.offsets
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
    import scipy.sparse as sp  # scipy loads only for the optimum: `import scanmesh` stays light

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
