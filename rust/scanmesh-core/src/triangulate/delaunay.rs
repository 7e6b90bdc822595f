//! Planar Delaunay triangulation, with the map back to input indices: delaunator's sweep
//! checked exactly, spade where the check fails.

use crate::budget::{try_collect, try_filled, try_vec};
use crate::geometry::{check_planar, orient2d, unit_square};
use crate::mesh::locality::sweep_order;
use crate::mesh::NONE;
use crate::mesh::{next, prev, HalfEdgeMesh};
use crate::progress::Progress;
use crate::{Error, Result};
use rayon::prelude::*;
use spade::{DelaunayTriangulation, HasPosition, Point2, Triangulation};
use std::collections::HashMap;

/// Peak memory of [`delaunay_trimmed`](crate::triangulate::delaunay_trimmed) per input point, checked
/// before it starts: the smallest address-space limit it ran under grows by about 390 bytes
/// a point (bisected on 200,000 and 800,000 points, docs/benchmarks/memory.md), plus room.
const PEAK_BYTES_PER_POINT: u64 = 450;

/// A Delaunay triangulation of planar points, in the caller's indices.
#[derive(Debug, Clone)]
pub struct Delaunay {
    /// Counter-clockwise triangles, each three input indices.
    pub triangles: Vec<[u32; 3]>,
    /// Half-edge twins: half-edge `3t + k` runs from corner k to corner k + 1 of triangle t;
    /// its twin is the reversed half-edge in the neighbouring triangle, `NONE` on the hull.
    pub twins: Vec<u32>,
    /// For each input point: `NONE` when it is a vertex of the triangulation, else the
    /// index of the earlier point with exactly the same planar coordinates that stands for it.
    pub duplicate_of: Vec<u32>,
}

impl Delaunay {
    /// Pairs (dropped point, the point that stands for it), in input order. O(n).
    pub fn duplicates(&self) -> Vec<(u32, u32)> {
        self.duplicate_of
            .iter()
            .enumerate()
            .filter(|(_, &k)| k != NONE)
            .map(|(i, &k)| (i as u32, k))
            .collect()
    }
}

/// spade's vertex type, carrying the input index through bulk loading's reordering.
struct IndexedPoint {
    position: Point2<f64>,
    index: u32,
}

impl HasPosition for IndexedPoint {
    type Scalar = f64;
    fn position(&self) -> Point2<f64> {
        self.position
    }
}

/// Delaunay triangulation of `uv` (planar points, finite). O(n log n).
///
/// Points with exactly equal coordinates are merged: the lowest index stays a vertex, the
/// others are listed in `duplicate_of`. Errors: fewer than 3 distinct points; all points
/// collinear (checked exactly before spade, whose bulk load is quadratic on such input).
///
/// delaunator's circle sweep (robust orientation, floating-point in-circle) runs first, about
/// twice as fast as spade's bulk load on scans, and its result is accepted only when exact
/// predicates prove it the unique Delaunay triangulation of the distinct points
/// (`proven`); anything else (cocircular points, near-duplicates it skipped, collinear
/// hull stretches closed by flat triangles) falls back to spade, which is exact throughout.
/// So the faces are the same whichever answers.
pub fn delaunay(uv: &[[f64; 2]]) -> Result<Delaunay> {
    let (mut d, order) = delaunay_ordered(uv, &Progress::new())?;
    if let Some(to_input) = order {
        relabel(&mut d.triangles, &to_input);
    }
    Ok(d)
}

/// [`delaunay`] with its triangles left in the labels it computed them in: `Some(to_input)`
/// when the sweep answered on the points relabelled in [`sweep_order`] (local vertex `v` is
/// input point `to_input[v]`), None when spade answered in input labels. `duplicate_of` is
/// in input labels either way. Passes over the triangles are cache-friendly in local labels
/// (consecutive triangles share nearby vertices), which is why the trimming stays in them.
/// `progress` gets [`DELAUNAY_PASSES`] × n points planned and counted, a pass at a time
/// (the sweep's insertions run inside delaunator, which counts nothing). O(n log n).
pub(crate) fn delaunay_ordered(
    uv: &[[f64; 2]],
    progress: &Progress,
) -> Result<(Delaunay, Option<Vec<u32>>)> {
    check_planar(uv)?;
    crate::budget::check_stage(
        || format!("Delaunay of {} points", uv.len()),
        PEAK_BYTES_PER_POINT.saturating_mul(uv.len() as u64),
    )?;
    let n = uv.len() as u64;
    progress.plan(DELAUNAY_PASSES * n);
    let before = progress.done();
    // what the passes not run (a sweep refused, spade answering) leave to count
    let rest = || progress.add((DELAUNAY_PASSES * n).saturating_sub(progress.done() - before));
    if uv.len() < (NONE / 8) as usize {
        let swept = {
            let unit = unit_square(uv);
            let order = sweep_order(&unit)?;
            progress.add(n);
            let local = try_collect(
                "Delaunay's points",
                order.iter().map(|&i| point(unit[i as usize])),
            )?;
            drop(unit);
            sweep_points(local, progress)?.map(|d| (d, order))
        };
        if let Some((mut d, to_input)) = swept {
            // Copies of a point keep their input order in the sweep order, so the lowest
            // local label of a copy is the lowest input index.
            let mut duplicate_of = try_filled("Delaunay's duplicates", NONE, uv.len())?;
            for (v, &k) in d.duplicate_of.iter().enumerate() {
                if k != NONE {
                    duplicate_of[to_input[v] as usize] = to_input[k as usize];
                }
            }
            d.duplicate_of = duplicate_of;
            rest();
            return Ok((d, Some(to_input)));
        }
    }
    let d = spade_delaunay(&unit_square(uv))?;
    rest();
    Ok((d, None))
}

/// Passes over the points [`delaunay_ordered`] counts in its `progress`: the sweep order,
/// the sweep, its proof.
pub(crate) const DELAUNAY_PASSES: u64 = 3;

/// Maps every vertex label `v` of `triangles` to `to_input[v]`, in parallel. O(m).
pub(crate) fn relabel(triangles: &mut [[u32; 3]], to_input: &[u32]) {
    triangles
        .par_iter_mut()
        .with_min_len(1 << 14)
        .for_each(|t| *t = t.map(|v| to_input[v as usize]));
}

/// delaunator on the unit-square points (fewer than `NONE / 8`), kept when [`proven`].
/// O(n log n).
#[cfg(test)]
fn sweep(unit: &[[f64; 2]]) -> Option<Delaunay> {
    sweep_points(unit.iter().map(|&p| point(p)).collect(), &Progress::new()).unwrap()
}

/// delaunator's point type. O(1).
fn point(p: [f64; 2]) -> delaunator::Point {
    delaunator::Point { x: p[0], y: p[1] }
}

/// `sweep` on the points already in delaunator's type: the only copy of the coordinates
/// while it runs (its peak is the call's). Ok(None) when the result is not proven; the
/// input-sized buffers after delaunator's own may fail to allocate (an
/// [`Error::OutOfMemory`]). Counts the points in `progress` once swept, again once proven.
/// O(n log n).
fn sweep_points(points: Vec<delaunator::Point>, progress: &Progress) -> Result<Option<Delaunay>> {
    let n = points.len() as u64;
    let delaunator::Triangulation {
        triangles: corners,
        halfedges,
        ..
    } = delaunator::triangulate(&points);
    progress.add(n);
    let unit = try_collect("Delaunay's unit points", points.iter().map(|p| [p.x, p.y]))?;
    drop(points);
    let unit = unit.as_slice();
    let m = corners.len() / 3;
    if m == 0 {
        return Ok(None);
    }
    // delaunator's triangles turn one way (clockwise for y up); ours turn the other. Reversing
    // corners 1 and 2 maps half-edge k of a triangle to half-edge 2 - k. Each usize array is
    // dropped once converted (48 MB apiece at 1M points).
    // The flip is its own inverse and keeps a half-edge in its triangle, so each triangle's
    // three twins are read from delaunator's three, in parallel.
    let flip = |h: usize| 3 * (h / 3) + 2 - h % 3;
    // Reserved fallibly, then filled in parallel (an indexed iterator writes in place).
    let mut triangles: Vec<[u32; 3]> = try_vec("Delaunay's triangles", m)?;
    triangles.par_extend(
        corners
            .par_chunks_exact(3)
            .with_min_len(1 << 14)
            .map(|t| [t[0] as u32, t[2] as u32, t[1] as u32]),
    );
    drop(corners);
    let mut twins: Vec<u32> = try_vec("Delaunay's twins", 3 * m)?;
    twins.par_extend((0..3 * m).into_par_iter().with_min_len(1 << 16).map(|h| {
        match halfedges[flip(h)] {
            delaunator::EMPTY => NONE,
            g => flip(g) as u32,
        }
    }));
    drop(halfedges);
    let Some(duplicate_of) = stand_ins(unit, &mut triangles)? else {
        return Ok(None);
    };
    let exact = proven(unit, &triangles, &twins)?;
    if exact {
        progress.add(n);
    }
    Ok(exact.then_some(Delaunay {
        triangles,
        twins,
        duplicate_of,
    }))
}

/// For points no triangle uses, the lowest index with the same coordinates, which becomes
/// the vertex (relabelled in `triangles`); Ok(None) when an unused point has no used twin
/// (a distinct point delaunator skipped). Errors: a per-point buffer that cannot be
/// allocated. O(n + m).
fn stand_ins(unit: &[[f64; 2]], triangles: &mut [[u32; 3]]) -> Result<Option<Vec<u32>>> {
    let mut used = try_filled("Delaunay's used points", false, unit.len())?;
    for &v in triangles.as_flattened() {
        used[v as usize] = true;
    }
    let mut duplicate_of = try_filled("Delaunay's duplicates", NONE, unit.len())?;
    if used.iter().all(|&u| u) {
        return Ok(Some(duplicate_of));
    }
    // -0.0 + 0.0 is 0.0: both zeros give one key, as == compares them.
    let key = |p: [f64; 2]| ((p[0] + 0.0).to_bits(), (p[1] + 0.0).to_bits());
    let mut lowest: HashMap<(u64, u64), u32> = (0..unit.len())
        .filter(|&i| !used[i])
        .map(|i| (key(unit[i]), NONE))
        .collect();
    let mut kept: HashMap<(u64, u64), u32> = HashMap::with_capacity(lowest.len());
    for (i, &p) in unit.iter().enumerate() {
        if let Some(low) = lowest.get_mut(&key(p)) {
            if *low == NONE {
                *low = i as u32;
            }
            if used[i] {
                kept.insert(key(p), i as u32);
            }
        }
    }
    let mut relabel: HashMap<u32, u32> = HashMap::new();
    for (k, &low) in &lowest {
        let Some(&vertex) = kept.get(k) else {
            return Ok(None);
        };
        relabel.insert(vertex, low);
    }
    for (i, &p) in unit.iter().enumerate() {
        let low = lowest.get(&key(p)).copied().unwrap_or(NONE);
        if low != NONE && low != i as u32 {
            duplicate_of[i] = low;
        }
    }
    for v in triangles.as_flattened_mut() {
        if let Some(&low) = relabel.get(v) {
            *v = low;
        }
    }
    Ok(Some(duplicate_of))
}

/// True when `triangles` with `twins` is, by exact predicates, the Delaunay triangulation of
/// the points it uses: twins mutual and reversed, every triangle strictly counter-clockwise,
/// one boundary loop that turns only left and winds once (one lowest point), V − E + F of a
/// disc, and every interior edge strictly locally Delaunay (in-circle < 0). Positive
/// triangles over a disc whose boundary winds once cover its inside exactly once (degree 1),
/// so this is a triangulation of the convex hull; strictly locally Delaunay everywhere means
/// it is the one Delaunay triangulation. Four cocircular points (exact grids) are refused,
/// so that where the Delaunay triangulation is not unique spade decides, as it always did.
/// Errors: its per-point buffers cannot be allocated. O(m).
fn proven(unit: &[[f64; 2]], triangles: &[[u32; 3]], twins: &[u32]) -> Result<bool> {
    let start = |h: u32| triangles[(h / 3) as usize][(h % 3) as usize];
    let at = |v: u32| unit[v as usize];
    let faces_ok = (0..triangles.len())
        .into_par_iter()
        .with_min_len(4096)
        .all(|t| {
            let [a, b, c] = triangles[t].map(at);
            if orient2d(a, b, c) <= 0.0 {
                return false;
            }
            (3 * t as u32..3 * t as u32 + 3).all(|h| {
                let g = twins[h as usize];
                if g == NONE {
                    return true;
                }
                if g as usize >= twins.len()
                    || twins[g as usize] != h
                    || start(g) != start(next(h))
                    || start(next(g)) != start(h)
                {
                    return false;
                }
                // Each interior edge once, from its lower half-edge.
                g < h || {
                    let d = at(start(prev(g)));
                    robust::incircle(coord(a), coord(b), coord(c), coord(d)) < 0.0
                }
            })
        });
    if !faces_ok {
        return Ok(false);
    }
    let mut boundary_out = try_filled("the exact check's boundary", NONE, unit.len())?;
    let mut n_boundary = 0u32;
    for (h, &g) in twins.iter().enumerate() {
        if g == NONE {
            let slot = &mut boundary_out[start(h as u32) as usize];
            if *slot != NONE {
                return Ok(false);
            }
            *slot = h as u32;
            n_boundary += 1;
        }
    }
    let Some(first) = twins.iter().position(|&g| g == NONE) else {
        return Ok(false);
    };
    let (mut h, mut steps, mut lowest) = (first as u32, 0u32, 0u32);
    let below = |p: [f64; 2], q: [f64; 2]| (p[1], p[0]) < (q[1], q[0]);
    loop {
        let following = boundary_out[start(next(h)) as usize];
        if following == NONE || steps > n_boundary {
            return Ok(false);
        }
        let (a, b, c) = (at(start(h)), at(start(next(h))), at(start(next(following))));
        if orient2d(a, b, c) < 0.0 {
            return Ok(false);
        }
        if below(b, a) && below(b, c) {
            lowest += 1;
        }
        steps += 1;
        h = following;
        if h == first as u32 {
            break;
        }
    }
    // The boundary slots are no longer needed: they become the vertices' seen flags.
    let mut seen = boundary_out;
    seen.fill(0);
    triangles
        .as_flattened()
        .iter()
        .for_each(|&v| seen[v as usize] = 1);
    let used = seen.iter().filter(|&&s| s != 0).count();
    // A disc: F = 2V − B − 2.
    Ok(steps == n_boundary && lowest == 1 && triangles.len() + n_boundary as usize + 2 == 2 * used)
}

fn coord(p: [f64; 2]) -> robust::Coord<f64> {
    robust::Coord { x: p[0], y: p[1] }
}

/// spade's bulk load of the distinct points, exact throughout. O(n log n).
pub(crate) fn spade_delaunay(unit: &[[f64; 2]]) -> Result<Delaunay> {
    let duplicate_of = find_duplicates(unit)?;
    let distinct: Vec<u32> = (0..unit.len() as u32)
        .filter(|&i| duplicate_of[i as usize] == NONE)
        .collect();
    if distinct.len() < 3 {
        return Err(Error::TooFewPoints {
            distinct: distinct.len(),
        });
    }
    if all_collinear(unit, &distinct) {
        return Err(Error::Collinear {
            after_projection: true,
        });
    }
    let vertices = distinct
        .iter()
        .map(|&i| {
            let [x, y] = unit[i as usize];
            IndexedPoint {
                position: Point2::new(x, y),
                index: i,
            }
        })
        .collect();
    let dt = DelaunayTriangulation::<IndexedPoint>::bulk_load(vertices).map_err(|e| {
        Error::InvalidParameter {
            name: "points",
            value: format!("{e:?}"),
            expected: "coordinates spade accepts",
        }
    })?;
    let triangles: Vec<[u32; 3]> = dt
        .inner_faces()
        .map(|f| {
            let [a, b, c] = f.vertices();
            let t = [a.data().index, b.data().index, c.data().index];
            // spade's faces are counter-clockwise; we promise it, so we make sure of it.
            if orient2d(
                unit[t[0] as usize],
                unit[t[1] as usize],
                unit[t[2] as usize],
            ) < 0.0
            {
                [t[0], t[2], t[1]]
            } else {
                t
            }
        })
        .collect();
    drop(dt);
    let mesh = HalfEdgeMesh::from_triangles(unit.len(), &triangles)?;
    let twins = (0..3 * triangles.len() as u32)
        .map(|h| mesh.twin(h))
        .collect();
    Ok(Delaunay {
        triangles,
        twins,
        duplicate_of,
    })
}

/// For each point, the lowest index of an earlier point with identical coordinates, or NONE.
/// Errors: its per-point buffers cannot be allocated. O(n log n) by sorting.
fn find_duplicates(uv: &[[f64; 2]]) -> Result<Vec<u32>> {
    let mut order = try_collect("Delaunay's point order", 0..uv.len() as u32)?;
    let key = |i: &u32| uv[*i as usize];
    order.sort_by(|a, b| {
        let (p, q) = (key(a), key(b));
        p[0].total_cmp(&q[0])
            .then(p[1].total_cmp(&q[1]))
            .then(a.cmp(b))
    });
    let mut duplicate_of = try_filled("Delaunay's duplicates", NONE, uv.len())?;
    let mut run_start = 0;
    for k in 1..order.len() {
        let (first, this) = (order[run_start], order[k]);
        // == (not total_cmp) so that -0.0 and 0.0 count as the same position.
        if uv[first as usize] == uv[this as usize] {
            duplicate_of[this as usize] = first;
        } else {
            run_start = k;
        }
    }
    Ok(duplicate_of)
}

/// True when all listed points lie on one line (exact predicate). O(n).
fn all_collinear(uv: &[[f64; 2]], ids: &[u32]) -> bool {
    let a = uv[ids[0] as usize];
    let b = uv[ids[1] as usize];
    ids[2..]
        .iter()
        .all(|&i| orient2d(a, b, uv[i as usize]) == 0.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::random_points;

    #[test]
    fn triangles_are_ccw_and_cover_all_points() {
        let pts = random_points(500, 7);
        let d = delaunay(&pts).unwrap();
        let mut used = vec![false; pts.len()];
        for t in &d.triangles {
            assert!(orient2d(pts[t[0] as usize], pts[t[1] as usize], pts[t[2] as usize]) > 0.0);
            for &v in t {
                used[v as usize] = true;
            }
        }
        assert!(used.iter().all(|&u| u));
    }

    #[test]
    fn duplicates_are_reported_not_dropped() {
        let mut pts = random_points(50, 3);
        pts.push(pts[10]);
        pts.push(pts[10]);
        pts.push([-0.0 + pts[4][0], pts[4][1]]);
        let d = delaunay(&pts).unwrap();
        assert_eq!(d.duplicates(), vec![(50, 10), (51, 10), (52, 4)]);
        assert!(d.triangles.iter().all(|t| t.iter().all(|&v| v < 50)));
        // The sweep answers here itself: a copy first in its order is relabelled to the
        // lowest index. Copies placed before their original check that relabelling.
        let mut early = vec![pts[30], pts[31]];
        early.extend(&pts);
        let fast = sweep(&unit_square(&early)).expect("exact copies do not defeat the sweep");
        assert_eq!(
            fast.duplicates(),
            vec![(32, 0), (33, 1), (52, 12), (53, 12), (54, 6)]
        );
        assert!(fast.triangles.iter().flatten().all(|&v| v != 32 && v != 33));
    }

    #[test]
    fn degenerate_inputs() {
        let line: Vec<[f64; 2]> = (0..10).map(|i| [i as f64, 2.0 * i as f64]).collect();
        assert_eq!(
            delaunay(&line).unwrap_err(),
            Error::Collinear {
                after_projection: true
            }
        );
        let two = vec![[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [0.0, 0.0]];
        assert_eq!(
            delaunay(&two).unwrap_err(),
            Error::TooFewPoints { distinct: 2 }
        );
        let nan = vec![[0.0, 0.0], [1.0, 0.0], [f64::NAN, 0.0]];
        assert!(matches!(
            delaunay(&nan),
            Err(Error::NonFinite { index: 2, .. })
        ));
    }

    #[test]
    fn exact_grids_keep_collinear_rows_collinear() {
        // A 10 x 10 grid off the origin, at scales where 1/half-extent is not a power of
        // two: every cell split in two (2 (n - 1)² triangles), no zero-area hull faces.
        for (scale, offset) in [(1.0, 0.3), (1e-300, 7.0), (1e300, -2.5), (3.0, 0.0)] {
            let uv: Vec<[f64; 2]> = (0..100)
                .map(|k| [((k % 10) as f64 + offset) * scale, (k / 10) as f64 * scale])
                .collect();
            let d = delaunay(&uv).unwrap();
            assert_eq!(d.triangles.len(), 2 * 9 * 9, "scale {scale}");
            let unit = unit_square(&uv);
            for t in &d.triangles {
                let [a, b, c] = t.map(|v| unit[v as usize]);
                assert!(orient2d(a, b, c) > 0.0);
            }
        }
    }

    #[test]
    fn unit_square_keeps_every_orientation_sign() {
        let mut pts = random_points(60, 5);
        // Exactly collinear triples that a rounding scale would bend.
        pts.extend([[0.1, 0.1], [0.2, 0.2], [0.3, 0.3], [1.0 / 3.0, 1.0 / 3.0]]);
        // At 2^±990 the reference signs are those of `pts` (the scaling is exact, and
        // orient2d of the scaled coordinates themselves would under- or overflow); at 3
        // (a rounding scale, whose 1 / half-extent is not a power of two) the scaled ones'.
        for s in [2f64.powi(-990), 3.0, 2f64.powi(990)] {
            let scaled: Vec<[f64; 2]> = pts.iter().map(|p| [p[0] * s, p[1] * s]).collect();
            let reference = if s == 3.0 { &scaled } else { &pts };
            let unit = unit_square(&scaled);
            assert!(unit.iter().flatten().all(|x| x.abs() <= 1.0));
            for i in 0..pts.len() {
                for j in (i + 1)..pts.len() {
                    for k in [(i + j) % pts.len(), pts.len() - 1] {
                        let sign = |p: &[[f64; 2]]| orient2d(p[i], p[j], p[k]).signum();
                        assert_eq!(sign(reference), sign(&unit), "scale {s}: {i} {j} {k}");
                    }
                }
            }
        }
    }

    fn canonical(mut t: Vec<[u32; 3]>) -> Vec<[u32; 3]> {
        for tri in t.iter_mut() {
            let k = (0..3).min_by_key(|&k| tri[k]).unwrap();
            tri.rotate_left(k);
        }
        t.sort();
        t
    }

    /// A jittered scan: `lines` rows of `per` points, as they arrive (line by line).
    fn scan(lines: usize, per: usize) -> Vec<[f64; 2]> {
        let jitter = random_points(lines * per, 17);
        (0..lines * per)
            .map(|k| {
                let (i, j) = ((k % per) as f64, (k / per) as f64);
                [
                    i + 0.1 * jitter[k][0] - 0.05,
                    2.0 * j + 0.1 * jitter[k][1] - 0.05,
                ]
            })
            .collect()
    }

    #[test]
    fn the_sweep_is_proven_and_equals_spade() {
        for uv in [random_points(2000, 3), scan(30, 70)] {
            let unit = unit_square(&uv);
            let fast = sweep(&unit).expect("a generic input passes the exact check");
            let exact = spade_delaunay(&unit).unwrap();
            assert_eq!(
                canonical(fast.triangles.clone()),
                canonical(exact.triangles)
            );
            // Twins: reversed half-edges, NONE exactly on the hull.
            let corner = |h: u32| fast.triangles[(h / 3) as usize][(h % 3) as usize];
            for (h, &g) in fast.twins.iter().enumerate() {
                let h = h as u32;
                if g != NONE {
                    assert_eq!((corner(g), corner(next(g))), (corner(next(h)), corner(h)));
                }
            }
            let mesh = HalfEdgeMesh::from_triangles(uv.len(), &fast.triangles).unwrap();
            let twins: Vec<u32> = (0..fast.twins.len() as u32).map(|h| mesh.twin(h)).collect();
            assert_eq!(twins, fast.twins);
        }
    }

    #[test]
    fn the_sweep_order_gives_spades_faces_on_any_thread_count() {
        // Random, a jittered scan, an exact grid (every cell cocircular: spade answers) with
        // copies of some points, and a scan with exactly collinear lines.
        let mut grid: Vec<[f64; 2]> = (0..400)
            .map(|k| [(k % 20) as f64, (k / 20) as f64])
            .collect();
        grid.extend([grid[7], grid[300], grid[7]]);
        let mut copies = scan(12, 40);
        copies.splice(0..0, [copies[100], copies[5]]);
        copies.push(copies[7]);
        let lines: Vec<[f64; 2]> = (0..600)
            .map(|k| {
                [
                    (k % 30) as f64 * 0.5 + 0.01 * (k % 7) as f64,
                    (k / 30) as f64,
                ]
            })
            .collect();
        for uv in [random_points(3000, 21), scan(40, 60), grid, copies, lines] {
            let exact = spade_delaunay(&unit_square(&uv)).unwrap();
            let pool = |threads| {
                rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap()
                    .install(|| delaunay(&uv).unwrap())
            };
            let (one, two) = (pool(1), pool(2));
            assert_eq!(one.triangles, two.triangles);
            assert_eq!(one.twins, two.twins);
            assert_eq!(
                canonical(one.triangles.clone()),
                canonical(exact.triangles.clone())
            );
            assert_eq!(one.duplicate_of, exact.duplicate_of);
            let mesh = HalfEdgeMesh::from_triangles(uv.len(), &one.triangles).unwrap();
            let twins: Vec<u32> = (0..one.twins.len() as u32).map(|h| mesh.twin(h)).collect();
            assert_eq!(twins, one.twins);
        }
        // Collinear input is refused on this path too.
        let line: Vec<[f64; 2]> = (0..50).map(|i| [i as f64, 0.5 * i as f64]).collect();
        assert!(delaunay(&line).is_err());
    }

    #[test]
    fn the_exact_check_refuses_what_is_not_delaunay() {
        let uv = random_points(300, 9);
        let unit = unit_square(&uv);
        let d = sweep(&unit).unwrap();
        assert!(proven(&unit, &d.triangles, &d.twins).unwrap());
        // Flip one interior edge: still a triangulation, no longer Delaunay.
        let h = (0..d.twins.len()).find(|&h| d.twins[h] != NONE).unwrap() as u32;
        let mut mesh = HalfEdgeMesh::from_triangles(uv.len(), &d.triangles).unwrap();
        let flippable = (h..d.twins.len() as u32)
            .find(|&h| mesh.twin(h) != NONE && mesh.can_flip(h, &unit))
            .unwrap();
        mesh.flip(flippable);
        let flipped = mesh.triangles().unwrap();
        let twins: Vec<u32> = (0..mesh.n_half_edges() as u32)
            .map(|h| mesh.twin(h))
            .collect();
        mesh.validate(&unit).unwrap();
        assert!(!proven(&unit, &flipped, &twins).unwrap());
        // A missing triangle (a hole) or a clockwise one is refused too.
        let mut holed = d.clone();
        let t = (d.twins.iter().position(|&g| g != NONE).unwrap() / 3) as u32;
        for k in 0..3 {
            let g = holed.twins[(3 * t + k) as usize];
            if g != NONE {
                holed.twins[g as usize] = NONE;
            }
            holed.twins[(3 * t + k) as usize] = NONE;
        }
        holed.triangles[t as usize] = holed.triangles[0];
        assert!(!proven(&unit, &holed.triangles, &holed.twins).unwrap());
        let mut turned = d.clone();
        turned.triangles[5].swap(1, 2);
        assert!(!proven(&unit, &turned.triangles, &turned.twins).unwrap());
    }

    #[test]
    fn degenerate_inputs_fall_back_to_spade() {
        // An exact grid: every cell cocircular, collinear hull rows; whichever path answers,
        // the faces are the grid's cells split in two, counter-clockwise.
        let grid: Vec<[f64; 2]> = (0..144)
            .map(|k| [(k % 12) as f64, (k / 12) as f64])
            .collect();
        let d = delaunay(&grid).unwrap();
        assert_eq!(d.triangles.len(), 2 * 11 * 11);
        // Points one ulp apart: delaunator may skip one as a near-duplicate; either way the
        // answer has both.
        let mut near = random_points(100, 4);
        near.push([f64::from_bits(near[7][0].to_bits() + 1), near[7][1]]);
        let d = delaunay(&near).unwrap();
        assert!(d.triangles.iter().flatten().any(|&v| v == 100));
        assert_eq!(d.duplicates(), vec![]);
        // A distinct point no triangle uses sends the sweep's answer back.
        let mut extra = random_points(100, 4);
        let mut t = sweep(&unit_square(&extra)).unwrap().triangles;
        extra.push([0.5, 0.500001]);
        assert!(stand_ins(&extra, &mut t).unwrap().is_none());
    }

    #[test]
    fn extreme_scales_give_the_same_connectivity() {
        let pts = random_points(200, 11);
        let base = delaunay(&pts).unwrap().triangles;
        let canon = canonical;
        for s in [1e-300, 1e-6, 1e6, 1e300] {
            let scaled: Vec<[f64; 2]> = pts.iter().map(|p| [p[0] * s, p[1] * s]).collect();
            assert_eq!(
                canon(delaunay(&scaled).unwrap().triangles),
                canon(base.clone()),
                "scale {s}"
            );
        }
    }
}
