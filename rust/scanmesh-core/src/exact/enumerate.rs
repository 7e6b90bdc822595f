//! Exhaustive enumeration for small inputs: the empty triangles of a planar point set and
//! every (fine) triangulation of its convex hull.
//!
//! Both are ground truth for exact optimization: the empty triangles are the candidate
//! variables of the tac-optimal mixed-integer program (`scanmesh.optimal`), and the list of
//! all triangulations is the brute force that checks it on a handful of points.
//!
//! A *triangulation* here always means a fine triangulation of the convex hull: every input
//! point is a vertex, the triangles cover the hull and meet only in common edges or
//! vertices. Its triangles are then exactly *empty*: no input point other than their three
//! corners lies in the closed triangle (a point on an edge would have to be a vertex on that
//! edge). Points on the hull's edges are boundary vertices in every triangulation.
//!
//! Enumeration walks the flip graph breadth first from a starting triangulation, flipping
//! with [`HalfEdgeMesh::can_flip`] / [`HalfEdgeMesh::flip`]. The flip graph of the
//! triangulations of a planar point set is connected (Lawson, *Transforming
//! triangulations*, Discrete Math. 3 (1972) 365–372: every triangulation flips to a
//! Delaunay one, and the Delaunay triangulations differ only inside cocircular convex
//! polygons, whose triangulations are flip-connected), so the walk reaches all of them.

use crate::geometry::{check_planar, orient2d};
use crate::mesh::HalfEdgeMesh;
use crate::mesh::NONE;
use crate::{Error, Result};
use rayon::prelude::*;
use std::collections::{HashSet, VecDeque};

/// Every non-degenerate triangle over `uv` whose closed area holds no other input point,
/// counter-clockwise, sorted (by first, second, third index after rotating the smallest
/// index first).
///
/// `uv` must be finite and pairwise distinct (merge coincident points first). Exact
/// predicates throughout: a triangle with three collinear corners, or with an input point
/// strictly inside or on one of its edges, is left out. Runs in parallel; O(n⁴) worst case
/// (each of the C(n, 3) triples is tested against the points within its x-range). For
/// random points about 2n² triangles are empty.
pub fn empty_triangles(uv: &[[f64; 2]]) -> Result<Vec<[u32; 3]>> {
    check_distinct(uv)?;
    let n = uv.len();
    // Points sorted by x, so that each triple tests only those within its x-range.
    let mut by_x: Vec<u32> = (0..n as u32).collect();
    by_x.sort_by(|&a, &b| uv[a as usize][0].total_cmp(&uv[b as usize][0]));
    let xs: Vec<f64> = by_x.iter().map(|&i| uv[i as usize][0]).collect();
    let mut found: Vec<[u32; 3]> = (0..n as u32)
        .into_par_iter()
        .flat_map_iter(|i| {
            let (by_x, xs) = (&by_x, &xs);
            ((i + 1)..n as u32).flat_map(move |j| {
                ((j + 1)..n as u32).filter_map(move |k| {
                    let (a, b, c) = (uv[i as usize], uv[j as usize], uv[k as usize]);
                    let o = orient2d(a, b, c);
                    if o == 0.0 {
                        return None;
                    }
                    let t = if o > 0.0 { [i, j, k] } else { [i, k, j] };
                    let (lo, hi) = (a[0].min(b[0]).min(c[0]), a[0].max(b[0]).max(c[0]));
                    let first = xs.partition_point(|&x| x < lo);
                    let last = xs.partition_point(|&x| x <= hi);
                    let occupied = by_x[first..last].iter().any(|&p| {
                        p != i && p != j && p != k && in_closed_triangle(uv, t, uv[p as usize])
                    });
                    (!occupied).then_some(t)
                })
            })
        })
        .collect();
    found.sort_unstable();
    Ok(found)
}

/// True when `p` lies in the closed counter-clockwise triangle `t` (exact). O(1).
#[inline]
fn in_closed_triangle(uv: &[[f64; 2]], t: [u32; 3], p: [f64; 2]) -> bool {
    let [a, b, c] = t.map(|v| uv[v as usize]);
    orient2d(a, b, p) >= 0.0 && orient2d(b, c, p) >= 0.0 && orient2d(c, a, p) >= 0.0
}

/// Errors unless every coordinate is finite and no two points coincide. O(n log n).
fn check_distinct(uv: &[[f64; 2]]) -> Result<()> {
    check_planar(uv)?;
    let mut order: Vec<usize> = (0..uv.len()).collect();
    order.sort_by(|&a, &b| {
        uv[a][0]
            .total_cmp(&uv[b][0])
            .then(uv[a][1].total_cmp(&uv[b][1]))
    });
    // == (not total_cmp) so that -0.0 and 0.0 count as the same position.
    if let Some(w) = order.windows(2).find(|w| uv[w[0]] == uv[w[1]]) {
        return Err(Error::InvalidParameter {
            name: "uv",
            value: format!(
                "points {} and {} at {:?}",
                w[0].min(w[1]),
                w[0].max(w[1]),
                uv[w[0]]
            ),
            expected: "pairwise distinct planar points (merge coincident points first)",
        });
    }
    Ok(())
}

/// The canonical form of a triangle list: each triangle rotated so that its smallest index
/// comes first (orientation kept), then the list sorted. Two lists describe the same
/// triangulation exactly when their canonical forms are equal. O(m log m).
pub fn canonical(triangles: &[[u32; 3]]) -> Vec<[u32; 3]> {
    let mut out: Vec<[u32; 3]> = triangles
        .iter()
        .map(|t| {
            let k = (0..3).min_by_key(|&k| t[k]).unwrap_or(0);
            let mut r = *t;
            r.rotate_left(k);
            r
        })
        .collect();
    out.sort_unstable();
    out
}

/// Checks that `mesh` is a fine triangulation of the convex hull of `uv`; the error says
/// what fails.
///
/// Conditions: [`HalfEdgeMesh::validate`] passes; every point is a vertex; no point lies
/// strictly right of any boundary half-edge (the boundary is convex and encloses all
/// points: this also rules out holes, as every hole has a point on the right of each of its
/// edges); and the triangle count is `2n − b − 2` for `b` boundary edges, which, with
/// validate's Euler check V − E + F = 2C − B and no holes, leaves exactly one disc. A
/// locally embedded disc whose boundary only turns left is embedded, so the triangles tile
/// the hull. O(n·b + m log m).
pub fn check_full_triangulation(uv: &[[f64; 2]], mesh: &HalfEdgeMesh) -> Result<()> {
    mesh.validate(uv)?;
    let fail = |s: String| Err(Error::Invariant(s));
    if let Some(v) = (0..uv.len() as u32).find(|&v| !mesh.is_used(v)) {
        return fail(format!(
            "point {v} is not a vertex: a triangulation must use every point"
        ));
    }
    let boundary: Vec<u32> = (0..mesh.n_half_edges() as u32)
        .filter(|&h| mesh.twin(h) == NONE)
        .collect();
    for &h in &boundary {
        let (a, b) = (mesh.start(h), mesh.end(h));
        if let Some(p) =
            (0..uv.len()).find(|&p| orient2d(uv[a as usize], uv[b as usize], uv[p]) < 0.0)
        {
            return fail(format!(
                "boundary edge {a}->{b} has point {p} on its outer side: the triangles do not fill the convex hull"
            ));
        }
    }
    let expected = 2 * uv.len() as i64 - boundary.len() as i64 - 2;
    if mesh.n_triangles() as i64 != expected {
        return fail(format!(
            "{} triangles, but one disc over {} points with {} boundary edges has {expected}",
            mesh.n_triangles(),
            uv.len(),
            boundary.len()
        ));
    }
    Ok(())
}

/// Every triangulation of the convex hull of `uv`, found by breadth-first search over edge
/// flips from `start`; each in `canonical` form, `start` first, in the order found.
///
/// `start` must be a triangulation of the hull using every point (checked with
/// `check_full_triangulation`); `uv` must be pairwise distinct. Errors with
/// `InvalidParameter { name: "max_count" }` as soon as more than `max_count` triangulations
/// are found (their number grows exponentially: Catalan(n − 2) for n points in convex
/// position). O(K·m·(m log m)) time and O(K·m) memory for K triangulations of m triangles.
pub fn triangulations(
    uv: &[[f64; 2]],
    start: &[[u32; 3]],
    max_count: usize,
) -> Result<Vec<Vec<[u32; 3]>>> {
    check_distinct(uv)?;
    let mesh = HalfEdgeMesh::from_triangles(uv.len(), start)?;
    check_full_triangulation(uv, &mesh)?;
    let too_many = |found: usize| Error::InvalidParameter {
        name: "max_count",
        value: max_count.to_string(),
        expected: if found > max_count {
            "at least the number of triangulations (more were found: raise max_count)"
        } else {
            "at least 1"
        },
    };
    if max_count == 0 {
        return Err(too_many(0));
    }
    let first = canonical(&mesh.triangles()?);
    let mut seen: HashSet<Vec<[u32; 3]>> = HashSet::from([first.clone()]);
    let mut found = vec![first];
    let mut queue = VecDeque::from([mesh]);
    while let Some(current) = queue.pop_front() {
        for h in current.interior_edges()? {
            if !current.can_flip(h, uv) {
                continue;
            }
            let mut flipped = current.clone();
            flipped.flip(h);
            let key = canonical(&flipped.triangles()?);
            if seen.contains(&key) {
                continue;
            }
            seen.insert(key.clone());
            found.push(key);
            if found.len() > max_count {
                return Err(too_many(found.len()));
            }
            queue.push_back(flipped);
        }
    }
    Ok(found)
}

/// Most labels a node of the fan DAG keeps; beyond it, neighbours (in P order) are merged
/// into their componentwise minimum, which keeps the search a valid lower bound.
pub const FAN_LABEL_CAP: usize = 64;

/// The cheapest fan around one vertex, as found by [`cheapest_fans`].
#[derive(Debug, Clone, PartialEq)]
pub struct CheapestFan {
    /// A lower bound on `min over fans of w·|Σ d| + Σ c`; equal to it when `exact`.
    pub lower_bound: f64,
    /// The cheapest fan found (triangle indices, counter-clockwise); empty when none closes.
    pub fan: Vec<u32>,
    /// Its value `w·|Σ d| + Σ c` (∞ when no fan closes).
    pub value: f64,
    /// True when no labels were merged: `value == lower_bound` is the exact minimum.
    pub exact: bool,
    /// Runners-up: the best fan of each other DAG pass (one per neighbour where fans
    /// close), with their values; extra columns for column generation.
    pub others: Vec<(f64, Vec<u32>)>,
}

/// The cheapest fan around each of `vertices`: over every cyclic sequence of candidate
/// triangles that closes exactly once around the vertex (a *fan*: the star of the vertex
/// in some triangulation), the minimum of `w·|Σ d| + Σ c`, a fan that attains it, and a
/// guaranteed lower bound.
///
/// `triangles` are counter-clockwise candidates (e.g. [`empty_triangles`]); `d[t][k]` and
/// `c[t][k]` belong to corner `k` of triangle `t` (for tac, `d` is the 3-D minus the planar
/// angle, so `Σ d` is the angle defect's negative, and `c` a dual price); `w[i] ≥ 0`
/// weighs `|Σ d|` at `vertices[i]`. This is the pricing problem of a Dantzig-Wolfe (fan)
/// reformulation of the tac MILP (see `scanmesh.optimal`).
///
/// Method: the triangles at v are arcs a → b between its neighbours in angular order; cut
/// the circle of directions by a ray in the gap crossed by the fewest arcs. Every fan has
/// exactly one arc across the ray (arcs turn by less than π, fans by exactly 2π), so a fan
/// is such an arc closed by a path in a DAG. The objective is `max(P, Q)` with the additive
/// `P = Σ (w d + c)` and `Q = Σ (−w d + c)`; labels keep the Pareto front of (P, Q), pruned
/// by shortest-path lower bounds and by the best value so far. Minimizing `|Σ d|` is a
/// subset-sum-like problem (fronts can be exponential), so a node keeps at most
/// `FAN_LABEL_CAP` labels: the rest are merged into componentwise minima, which lower
/// every value they stand for. The result is then a valid lower bound and a real fan, and
/// `exact` says whether they coincide. O(m·(cap·deg)·log) per DAG pass for m neighbours,
/// one pass per neighbour with arcs across the ray; vertices run in parallel.
///
/// Errors when array lengths disagree, an index is out of range, or a value is not finite
/// (`w` also negative).
pub fn cheapest_fans(
    uv: &[[f64; 2]],
    triangles: &[[u32; 3]],
    d: &[[f64; 3]],
    c: &[[f64; 3]],
    vertices: &[u32],
    w: &[f64],
) -> Result<Vec<CheapestFan>> {
    cheapest_fans_capped(uv, triangles, d, c, vertices, w, FAN_LABEL_CAP)
}

/// [`cheapest_fans`] with `cap` labels per node (tests use tiny caps to force merging).
fn cheapest_fans_capped(
    uv: &[[f64; 2]],
    triangles: &[[u32; 3]],
    d: &[[f64; 3]],
    c: &[[f64; 3]],
    vertices: &[u32],
    w: &[f64],
    cap: usize,
) -> Result<Vec<CheapestFan>> {
    let bad = |name: &'static str, value: String, expected: &'static str| {
        Err(Error::InvalidParameter {
            name,
            value,
            expected,
        })
    };
    if d.len() != triangles.len() || c.len() != triangles.len() {
        return bad(
            "d, c",
            format!("{} and {} rows", d.len(), c.len()),
            "one row per triangle",
        );
    }
    if w.len() != vertices.len() {
        return bad("w", format!("{} weights", w.len()), "one weight per vertex");
    }
    if let Some(t) = triangles
        .iter()
        .position(|t| t.iter().any(|&v| v as usize >= uv.len()))
    {
        return bad(
            "triangles",
            format!("row {t}"),
            "vertex indices below the number of points",
        );
    }
    if let Some(&v) = vertices.iter().find(|&&v| v as usize >= uv.len()) {
        return bad(
            "vertices",
            v.to_string(),
            "indices below the number of points",
        );
    }
    if d.iter().chain(c).flatten().any(|x| !x.is_finite()) {
        return bad("d, c", "a non-finite entry".into(), "finite values");
    }
    if let Some(x) = w.iter().find(|x| !(x.is_finite() && **x >= 0.0)) {
        return bad("w", x.to_string(), "finite weights >= 0");
    }
    // Corners (triangle, k) around each vertex.
    let mut around: Vec<Vec<(u32, u8)>> = vec![Vec::new(); uv.len()];
    for (t, tri) in triangles.iter().enumerate() {
        for k in 0..3 {
            around[tri[k] as usize].push((t as u32, k as u8));
        }
    }
    Ok(vertices
        .par_iter()
        .zip(w.par_iter())
        .map(|(&v, &weight)| {
            let arcs: Vec<Arc> = around[v as usize]
                .iter()
                .map(|&(t, k)| {
                    let tri = triangles[t as usize];
                    let (dk, ck) = (d[t as usize][k as usize], c[t as usize][k as usize]);
                    Arc {
                        from: tri[(k as usize + 1) % 3],
                        to: tri[(k as usize + 2) % 3],
                        triangle: t,
                        p: weight * dk + ck,
                        q: -weight * dk + ck,
                    }
                })
                .collect();
            cheapest_fan(uv, v, &arcs, cap)
        })
        .collect())
}

/// A triangle (v, from, to) seen from v: an arc turning counter-clockwise from `from` to
/// `to`, with its two additive weights.
#[derive(Debug, Clone, Copy)]
struct Arc {
    from: u32,
    to: u32,
    triangle: u32,
    p: f64,
    q: f64,
}

/// A partial path in the fan DAG: its (P, Q) so far (a lower bound when `merged`), its
/// last arc and the label before.
#[derive(Debug, Clone, Copy)]
struct Label {
    p: f64,
    q: f64,
    arc: u32,
    parent: u32,
    merged: bool,
}

/// Counter-clockwise angular order of the directions from `v` to `a` and `b`, exactly:
/// first by half-plane (starting along +u), then by orientation. Distinct neighbours of a
/// vertex in empty triangles never share a direction.
fn angular_cmp(uv: &[[f64; 2]], v: u32, a: u32, b: u32) -> std::cmp::Ordering {
    let o = uv[v as usize];
    let half = |p: [f64; 2]| {
        let (dx, dy) = (p[0] - o[0], p[1] - o[1]); // exact signs (Sterbenz)
        u8::from(!(dy > 0.0 || (dy == 0.0 && dx > 0.0)))
    };
    let (pa, pb) = (uv[a as usize], uv[b as usize]);
    half(pa).cmp(&half(pb)).then_with(|| {
        let turn = orient2d(o, pa, pb);
        0.0f64
            .partial_cmp(&turn)
            .unwrap_or(std::cmp::Ordering::Equal)
    })
}

/// The cheapest fan of one vertex (see [`cheapest_fans`]).
fn cheapest_fan(uv: &[[f64; 2]], v: u32, arcs: &[Arc], cap: usize) -> CheapestFan {
    let none = CheapestFan {
        lower_bound: f64::INFINITY,
        fan: Vec::new(),
        value: f64::INFINITY,
        exact: true,
        others: Vec::new(),
    };
    let mut nb: Vec<u32> = arcs.iter().flat_map(|a| [a.from, a.to]).collect();
    nb.sort_unstable();
    nb.dedup();
    nb.sort_by(|&a, &b| angular_cmp(uv, v, a, b));
    let m = nb.len();
    if m < 3 {
        return none;
    }
    let sorted_pos = |x: u32| {
        nb.binary_search_by(|&y| angular_cmp(uv, v, y, x))
            .unwrap_or(0)
    };
    let raw: Vec<(usize, usize)> = arcs
        .iter()
        .map(|a| (sorted_pos(a.from), sorted_pos(a.to)))
        .collect();
    // Ray in the gap (before position g) crossed by the fewest arcs: arc f -> t crosses the
    // gaps f+1 ..= t, cyclically.
    let mut diff = vec![0i64; m + 1];
    for &(f, t) in &raw {
        let (lo, hi) = (f + 1, t);
        if lo <= hi {
            diff[lo] += 1;
            diff[hi + 1] -= 1;
        } else {
            diff[lo] += 1;
            diff[m] -= 1;
            diff[0] += 1;
            diff[hi + 1] -= 1;
        }
    }
    let (mut run, mut gap, mut fewest) = (0i64, 0usize, i64::MAX);
    for (g, dv) in diff.iter().take(m).enumerate() {
        run += dv;
        let crossing = run;
        if crossing < fewest {
            fewest = crossing;
            gap = g;
        }
    }
    let ends: Vec<(usize, usize)> = raw
        .iter()
        .map(|&(f, t)| ((f + m - gap) % m, (t + m - gap) % m))
        .collect();
    let mut forward: Vec<Vec<u32>> = vec![Vec::new(); m];
    let mut wraps_into: Vec<Vec<u32>> = vec![Vec::new(); m];
    for (i, &(f, t)) in ends.iter().enumerate() {
        if f < t {
            forward[f].push(i as u32);
        } else {
            wraps_into[f].push(i as u32); // a -> b with b before a: a path b -> a closes it
        }
    }
    let mut threshold = f64::INFINITY; // every pruned or final label is >= this
    let mut best_real = (f64::INFINITY, Vec::new());
    let mut per_pass: Vec<(f64, Vec<u32>)> = Vec::new();
    let mut exact = true;
    let mut arena: Vec<Label> = Vec::new();
    let mut pending: Vec<Vec<u32>> = vec![Vec::new(); m];
    let (mut lb_p, mut lb_q) = (vec![f64::INFINITY; m], vec![f64::INFINITY; m]);
    for pa in 0..m {
        if wraps_into[pa].is_empty() {
            continue;
        }
        let start = wraps_into[pa]
            .iter()
            .map(|&e| ends[e as usize].1)
            .min()
            .unwrap_or(pa);
        for x in lb_p[start..=pa]
            .iter_mut()
            .chain(lb_q[start..=pa].iter_mut())
        {
            *x = f64::INFINITY;
        }
        lb_p[pa] = 0.0;
        lb_q[pa] = 0.0;
        for i in (start..pa).rev() {
            for &e in &forward[i] {
                let j = ends[e as usize].1;
                if j <= pa {
                    let a = &arcs[e as usize];
                    lb_p[i] = lb_p[i].min(a.p + lb_p[j]);
                    lb_q[i] = lb_q[i].min(a.q + lb_q[j]);
                }
            }
        }
        let bound = |l: &Label, i: usize| (l.p + lb_p[i]).max(l.q + lb_q[i]);
        arena.clear();
        for f in pending[start..=pa].iter_mut() {
            f.clear();
        }
        for &e in &wraps_into[pa] {
            let a = &arcs[e as usize];
            let l = Label {
                p: a.p,
                q: a.q,
                arc: e,
                parent: u32::MAX,
                merged: false,
            };
            let pb = ends[e as usize].1;
            if bound(&l, pb) < threshold {
                pending[pb].push(arena.len() as u32);
                arena.push(l);
            }
        }
        for i in start..=pa {
            let mut here = std::mem::take(&mut pending[i]);
            here.retain(|&k| bound(&arena[k as usize], i) < threshold);
            // Pareto front in (P, Q): by P ascending, keep strictly falling Q.
            here.sort_by(|&x, &y| {
                let (a, b) = (&arena[x as usize], &arena[y as usize]);
                a.p.total_cmp(&b.p).then(a.q.total_cmp(&b.q))
            });
            let mut front: Vec<u32> = Vec::with_capacity(here.len());
            for k in here {
                if front
                    .last()
                    .is_none_or(|&f| arena[k as usize].q < arena[f as usize].q)
                {
                    front.push(k);
                }
            }
            if front.len() > cap {
                exact = false;
                front = merge_front(&mut arena, &front, cap);
            }
            if i == pa {
                let mut pass_best = (f64::INFINITY, u32::MAX);
                for &k in &front {
                    let l = arena[k as usize];
                    let value = l.p.max(l.q);
                    threshold = threshold.min(value);
                    let real = if l.merged {
                        path_value(&arena, k, arcs)
                    } else {
                        value
                    };
                    if real < pass_best.0 {
                        pass_best = (real, k);
                    }
                }
                if pass_best.1 != u32::MAX {
                    let found = (pass_best.0, path(&arena, pass_best.1, arcs));
                    if found.0 < best_real.0 {
                        best_real = found.clone();
                    }
                    per_pass.push(found);
                }
                break;
            }
            for &k in &front {
                let here_label = arena[k as usize];
                for &e in &forward[i] {
                    let j = ends[e as usize].1;
                    if j > pa {
                        continue;
                    }
                    let a = &arcs[e as usize];
                    let l = Label {
                        p: here_label.p + a.p,
                        q: here_label.q + a.q,
                        arc: e,
                        parent: k,
                        merged: here_label.merged,
                    };
                    if bound(&l, j) < threshold {
                        pending[j].push(arena.len() as u32);
                        arena.push(l);
                    }
                }
            }
        }
    }
    if best_real.1.is_empty() {
        return none;
    }
    let lower_bound = threshold.min(best_real.0);
    let others = per_pass
        .into_iter()
        .filter(|(_, f)| *f != best_real.1)
        .collect();
    CheapestFan {
        lower_bound,
        exact: exact && lower_bound == best_real.0,
        value: best_real.0,
        fan: best_real.1,
        others,
    }
}

/// Merges a Pareto front (by P ascending) into at most `cap` labels, each the
/// componentwise minimum of a run of neighbours; the member with the smallest P + Q (the
/// cheapest prices) carries the path. O(len).
fn merge_front(arena: &mut Vec<Label>, front: &[u32], cap: usize) -> Vec<u32> {
    let group = front.len().div_ceil(cap);
    front
        .chunks(group)
        .map(|run| {
            if run.len() == 1 {
                return run[0];
            }
            let (mut p, mut q) = (f64::INFINITY, f64::INFINITY);
            let mut carrier = run[0];
            for &k in run {
                let l = arena[k as usize];
                p = p.min(l.p);
                q = q.min(l.q);
                let c = arena[carrier as usize];
                if l.p + l.q < c.p + c.q {
                    carrier = k;
                }
            }
            let c = arena[carrier as usize];
            arena.push(Label {
                p,
                q,
                arc: c.arc,
                parent: c.parent,
                merged: true,
            });
            (arena.len() - 1) as u32
        })
        .collect()
}

/// The arcs' triangles along the path ending in label `k`, in fan order.
fn path(arena: &[Label], mut k: u32, arcs: &[Arc]) -> Vec<u32> {
    let mut out = Vec::new();
    while k != u32::MAX {
        out.push(arcs[arena[k as usize].arc as usize].triangle);
        k = arena[k as usize].parent;
    }
    out.reverse();
    out
}

/// The true `max(P, Q)` of the path ending in label `k` (merged labels only bound it).
fn path_value(arena: &[Label], mut k: u32, arcs: &[Arc]) -> f64 {
    let (mut p, mut q) = (0.0, 0.0);
    while k != u32::MAX {
        let a = &arcs[arena[k as usize].arc as usize];
        p += a.p;
        q += a.q;
        k = arena[k as usize].parent;
    }
    p.max(q)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::random_points;
    use crate::triangulate::delaunay::delaunay;

    fn all(uv: &[[f64; 2]], cap: usize) -> Result<Vec<Vec<[u32; 3]>>> {
        let d = delaunay(uv)?;
        triangulations(uv, &d.triangles, cap)
    }

    fn catalan(k: u64) -> u64 {
        (0..k).fold(1u64, |c, i| c * 2 * (2 * i + 1) / (i + 2))
    }

    fn binomial(n: u64, k: u64) -> u64 {
        (0..k).fold(1u64, |c, i| c * (n - i) / (i + 1))
    }

    fn grid(cols: usize, rows: usize) -> Vec<[f64; 2]> {
        (0..rows)
            .flat_map(|j| (0..cols).map(move |i| [i as f64, j as f64]))
            .collect()
    }

    #[test]
    fn convex_polygons_have_catalan_many_triangulations() {
        for n in 3..=11usize {
            let uv: Vec<[f64; 2]> = (0..n)
                .map(|k| {
                    let a = std::f64::consts::TAU * k as f64 / n as f64 + 0.1;
                    [a.cos(), 0.7 * a.sin()]
                })
                .collect();
            let found = all(&uv, 100_000).unwrap();
            assert_eq!(found.len() as u64, catalan(n as u64 - 2), "{n}-gon");
            // In convex position every triangle is empty.
            assert_eq!(
                empty_triangles(&uv).unwrap().len() as u64,
                binomial(n as u64, 3)
            );
        }
    }

    #[test]
    fn lattice_grids_match_the_known_counts() {
        // Unimodular triangulations of the 1 x k lattice rectangle: C(2k, k); of 2 x 2: 64;
        // of 2 x 3: 852 (Kaibel and Ziegler, Counting lattice triangulations, 2003).
        // Collinear points on the hull's edges and cocircular squares everywhere.
        for k in 1..=5usize {
            assert_eq!(
                all(&grid(k + 1, 2), 1_000_000).unwrap().len() as u64,
                binomial(2 * k as u64, k as u64)
            );
        }
        assert_eq!(all(&grid(3, 3), 1_000).unwrap().len(), 64);
        assert_eq!(all(&grid(4, 3), 10_000).unwrap().len(), 852);
    }

    #[test]
    fn every_enumerated_triangulation_is_distinct_full_and_made_of_empty_triangles() {
        for seed in 0..6 {
            let uv = random_points(9, seed);
            let empty: HashSet<[u32; 3]> = empty_triangles(&uv).unwrap().into_iter().collect();
            let found = all(&uv, 100_000).unwrap();
            let distinct: HashSet<&Vec<[u32; 3]>> = found.iter().collect();
            assert_eq!(distinct.len(), found.len());
            for t in &found {
                let mesh = HalfEdgeMesh::from_triangles(uv.len(), t).unwrap();
                check_full_triangulation(&uv, &mesh).unwrap();
                assert!(
                    t.iter().all(|tri| empty.contains(tri)),
                    "a non-empty triangle was used"
                );
            }
        }
    }

    #[test]
    fn square_with_centre() {
        // The centre lies on both diagonals: only the four triangles around it are empty.
        let uv = vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.5, 0.5]];
        assert_eq!(
            empty_triangles(&uv).unwrap(),
            vec![[0, 1, 4], [0, 4, 3], [1, 2, 4], [2, 3, 4]]
        );
        assert_eq!(all(&uv, 10).unwrap().len(), 1);
        // Off-centre, inside triangle (0, 1, 2): the quad has 3 fine triangulations.
        let uv = vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.7, 0.4]];
        assert_eq!(all(&uv, 10).unwrap().len(), 3);
    }

    #[test]
    fn the_cap_is_an_error_not_a_truncation() {
        let uv: Vec<[f64; 2]> = (0..9)
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / 9.0;
                [a.cos(), a.sin()]
            })
            .collect();
        assert_eq!(all(&uv, 429).unwrap().len(), 429);
        assert!(matches!(
            all(&uv, 428),
            Err(Error::InvalidParameter {
                name: "max_count",
                ..
            })
        ));
        assert!(matches!(
            all(&uv, 0),
            Err(Error::InvalidParameter {
                name: "max_count",
                ..
            })
        ));
    }

    #[test]
    fn bad_inputs_are_errors() {
        let dup = vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 0.0]];
        assert!(matches!(
            empty_triangles(&dup),
            Err(Error::InvalidParameter { name: "uv", .. })
        ));
        let nan = vec![[0.0, 0.0], [1.0, f64::NAN], [0.0, 1.0]];
        assert!(matches!(
            empty_triangles(&nan),
            Err(Error::NonFinite {
                index: 1,
                axis: 1,
                ..
            })
        ));
        // A start that leaves out the interior point, or only half the square.
        let uv = vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.7, 0.4]];
        assert!(triangulations(&uv, &[[0, 1, 2], [0, 2, 3]], 10).is_err());
        let square = vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        let err = triangulations(&square, &[[0, 1, 2], [0, 2, 3], [0, 1, 2]], 10).unwrap_err();
        assert!(matches!(err, Error::InvalidFace { .. }), "{err}");
        let half = vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]];
        assert!(triangulations(&half, &[[0, 1, 2]], 10).is_ok());
        let err = triangulations(
            &square[..3]
                .iter()
                .chain([[0.2, 0.9]].iter())
                .copied()
                .collect::<Vec<_>>(),
            &[[0, 1, 2]],
            10,
        )
        .unwrap_err();
        assert!(format!("{err}").contains("not a vertex"), "{err}");
    }
    #[test]
    fn cheapest_fans_match_every_fan_of_every_triangulation() {
        // Every fan of empty triangles is the star of its vertex in some triangulation, so
        // the brute-force minimum over all triangulations' stars is the exact answer.
        let mut s = 7u64;
        let mut rand = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let (mut exact_seen, mut inexact_seen) = (0, 0);
        for seed in 0..8 {
            let uv = random_points(10, 100 + seed);
            let tri = empty_triangles(&uv).unwrap();
            let d: Vec<[f64; 3]> = tri.iter().map(|_| [rand(), rand(), rand()]).collect();
            let c: Vec<[f64; 3]> = tri.iter().map(|_| [rand(), rand(), rand()]).collect();
            let index: std::collections::HashMap<[u32; 3], usize> =
                tri.iter().enumerate().map(|(i, &t)| (t, i)).collect();
            let all = all(&uv, 100_000).unwrap();
            let mesh = HalfEdgeMesh::from_triangles(uv.len(), &all[0]).unwrap();
            let inner: Vec<u32> = (0..uv.len() as u32)
                .filter(|&v| mesh.is_interior(v))
                .collect();
            let w: Vec<f64> = inner
                .iter()
                .map(|&v| [0.0, 1.0, 2.5][v as usize % 3])
                .collect();
            for cap in [FAN_LABEL_CAP, 3, 1] {
                let got = cheapest_fans_capped(&uv, &tri, &d, &c, &inner, &w, cap).unwrap();
                for (i, &v) in inner.iter().enumerate() {
                    let star_value = |t: &Vec<[u32; 3]>| {
                        let (mut sd, mut sc) = (0.0, 0.0);
                        for f in t.iter().filter(|f| f.contains(&v)) {
                            let j = index[f];
                            let k = f.iter().position(|&x| x == v).unwrap();
                            sd += d[j][k];
                            sc += c[j][k];
                        }
                        w[i] * f64::abs(sd) + sc
                    };
                    let truth = all.iter().map(star_value).fold(f64::INFINITY, f64::min);
                    let found = &got[i];
                    assert!(
                        found.lower_bound <= truth + 1e-12,
                        "seed {seed} vertex {v}: bound above the minimum"
                    );
                    assert!(found.value >= truth - 1e-12);
                    if found.exact {
                        assert!(
                            (found.value - truth).abs() < 1e-12,
                            "seed {seed} vertex {v}: {} vs {truth}",
                            found.value
                        );
                    }
                    exact_seen += usize::from(found.exact);
                    inexact_seen += usize::from(!found.exact);
                    // The fan returned is a real star with that value.
                    let fan = &found.fan;
                    let as_list: Vec<[u32; 3]> = fan.iter().map(|&t| tri[t as usize]).collect();
                    let k = as_list.len();
                    for (j, t) in as_list.iter().enumerate() {
                        let next = as_list[(j + 1) % k];
                        let at = |t: &[u32; 3]| t.iter().position(|&x| x == v).unwrap();
                        assert_eq!(t[(at(t) + 2) % 3], next[(at(&next) + 1) % 3], "consecutive");
                    }
                    let (mut sd, mut sc) = (0.0, 0.0);
                    for (&t, f) in fan.iter().zip(&as_list) {
                        let kk = f.iter().position(|&x| x == v).unwrap();
                        sd += d[t as usize][kk];
                        sc += c[t as usize][kk];
                    }
                    assert!((w[i] * f64::abs(sd) + sc - found.value).abs() < 1e-12);
                }
            }
            // A hull vertex has no fan.
            let hull = (0..uv.len() as u32)
                .find(|&v| !mesh.is_interior(v))
                .unwrap();
            let none = cheapest_fans(&uv, &tri, &d, &c, &[hull], &[1.0]).unwrap();
            assert!(none[0].value.is_infinite() && none[0].fan.is_empty());
        }
        assert!(exact_seen > 10, "the exact path is exercised");
        assert!(inexact_seen > 10, "the merging path is exercised");
        let uv = random_points(5, 1);
        let tri = empty_triangles(&uv).unwrap();
        let z = vec![[0.0; 3]; tri.len()];
        assert!(cheapest_fans(&uv, &tri, &z, &z, &[0], &[-1.0]).is_err());
        assert!(cheapest_fans(&uv, &tri, &z[1..], &z, &[0], &[1.0]).is_err());
        assert!(cheapest_fans(&uv, &tri, &z, &z, &[9], &[1.0]).is_err());
    }
}
