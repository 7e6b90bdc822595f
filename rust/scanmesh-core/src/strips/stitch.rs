//! Strips between consecutive scan lines, stitched into one mesh over the caller's points.
//!
//! For each pair of consecutive lines (lines without a segment of two points or more are
//! passed over: a one-point line contributes no strip of its own), every segment of the
//! first is joined to every segment of the second that overlaps it along the scan
//! direction. The scan direction of a pair is the sum of the two lines' chords (first to
//! last point, the second turned round when the lines run opposite ways, as in zig-zag
//! scans); t is the planar position along it. Two segments with t-ranges [t0, t1] and
//! [s0, s1] overlap when max(t0, s0) − min(t1, s1) ≤ e, with e = half the gap length of
//! [`crate::strips::lines`]; the strip then uses the points of each segment whose t lies in
//! [max(t0, s0) − e, min(t1, s1) + e]. Clipping to the overlap keeps strips from bridging
//! holes (beside a gap of the neighbour line, a segment's points stay on the boundary);
//! the margin e lets a line end overhang its neighbour's by less than half a gap, as lines
//! of unequal length do, and still be used. Two windows on one segment never overlap,
//! because the segments they face are more than a gap apart.
//!
//! Each strip is a path through the Fuchs matrix ([`crate::strips::fuchs`]) of its two clipped
//! segments; strips are independent and run in parallel (rayon). All lines are first
//! turned to run the same way, so that every line's edges run one way in the strip before
//! it and the other way in the strip after it: the strips fit together with one
//! consistent orientation even where lines cross in the plane. The whole mesh is then
//! turned counter-clockwise in the plane (by the sign of its total planar area). Points of
//! one-point segments and lines are then inserted into the triangle
//! (or the edge) that contains them in the plane, if any. The result is checked as
//! [`HalfEdgeMesh::validate`] would check it: decided from the strips themselves while they
//! are solved when they fit together as strips do (`strips/check.rs`, which proves the two
//! checks equivalent), else by building the half-edge mesh and validating it, which also
//! names every error; a failure (crossing lines, a pinch) is reported in
//! [`StripMesh::planar_error`], never as a panic, and the 3-D mesh is still returned.

use super::{check, jumps, repair, Method, ScanContext, StripMesh, StripParams, Task, BLOCK};
use crate::budget::{try_filled, try_indices, try_par_collect, try_vec};
use crate::geometry::{check_finite, orient2d, Normalizer};
use crate::geometry::{unit_square_scaled, unit_square_scaled_by};
use crate::mesh::HalfEdgeMesh;
use crate::progress::Progress;
use crate::strips::fuchs::{lookahead, path_triangles_into, shortest_path, Weight};
use crate::strips::lines::ScanLines;
use crate::triangulate::jumps::{check_jump_factor, DepthJumps};
use crate::{Error, Result};
use glam::DVec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};

/// Coefficient of the edge length (in median steps) added to every weight to break ties:
/// on a flat strip every path has the same area and no dihedral angle, and without it the
/// choice among equals (a fan of slivers) would be an accident of the search order. Far
/// below any real difference (a millionth of a step per edge).
pub const TIE_BREAK: f64 = 1e-6;

/// Peak memory of [`stitch_part`] per input point, checked before it starts: a whole
/// shortest-path run (Python's part included) needs about 130 bytes a point more address
/// space (bisected on 200,000 and 800,000 points, docs/benchmarks/memory.md), plus room.
const PEAK_BYTES_PER_POINT: u64 = 250;

/// The part of `segment` whose t lies in [lo, hi] (in (lo, hi] when `open`), and the index
/// of its first point in `segment`. Segments run in their line's oriented direction,
/// nearly monotone in t, so the ends are trimmed from outside in. O(len).
fn clip(segment: &[u32], t: impl Fn(u32) -> f64, lo: f64, open: bool, hi: f64) -> (Vec<u32>, u32) {
    let start = segment
        .iter()
        .position(|&k| if open { t(k) > lo } else { t(k) >= lo })
        .unwrap_or(segment.len());
    let end = segment
        .iter()
        .rposition(|&k| t(k) <= hi)
        .map_or(0, |e| e + 1);
    if start >= end {
        return (Vec::new(), 0);
    }
    (segment[start..end].to_vec(), start as u32)
}

/// The chord of a line in the plane: from its first point to its last. O(1).
fn chord(uv: &[[f64; 2]], line: &[Vec<u32>]) -> [f64; 2] {
    let first = uv[line[0][0] as usize];
    let last = uv[*line
        .last()
        .and_then(|s| s.last())
        .expect("segments are not empty") as usize];
    [last[0] - first[0], last[1] - first[1]]
}

/// A segment's index in its line and its t-range.
type Span = (usize, f64, f64);

/// Where segment `x`'s window for the partner `partners[j]` may lie: (lower bound, whether
/// it is open, upper bound). Partners (segments of the other line overlapping `x`, in
/// order of t) share `x` at the midpoints between them, a point on a midpoint going to the
/// lower one, so that the windows on `x` are disjoint even where its partners are closer
/// than two margins (pieces cut at a depth jump, one step apart). O(1).
fn share(partners: &[Span], j: usize) -> (f64, bool, f64) {
    let cut = |i: usize| 0.5 * partners[i].2 + 0.5 * partners[i + 1].1;
    let lo = if j > 0 { cut(j - 1) } else { f64::NEG_INFINITY };
    let hi = if j + 1 < partners.len() {
        cut(j)
    } else {
        f64::INFINITY
    };
    (lo, j > 0, hi)
}

/// The strips between oriented lines `p` and `q` (both running the same way): every
/// overlapping pair of their segments, each window also within its share of its segment
/// (see [`share`]). O(s_p · s_q · log + points).
fn pair_tasks(
    uv: &[[f64; 2]],
    lines: &[Vec<Vec<u32>>],
    p: usize,
    q: usize,
    margin: f64,
    out: &mut Vec<Task>,
) {
    let (c, d) = (chord(uv, &lines[p]), chord(uv, &lines[q]));
    let axis = [c[0] + d[0], c[1] + d[1]];
    let t = |k: u32| uv[k as usize][0] * axis[0] + uv[k as usize][1] * axis[1];
    // t is in units of |axis|: scale the margin to match.
    let margin = margin * axis[0].hypot(axis[1]);
    let spans = |line: usize| -> Vec<Span> {
        lines[line]
            .iter()
            .enumerate()
            .filter(|(_, s)| s.len() >= 2)
            .map(|(k, s)| {
                let (x, y) = (t(s[0]), t(s[s.len() - 1]));
                (k, x.min(y), x.max(y))
            })
            .collect()
    };
    let overlap = |a: &Span, b: &Span| a.1.max(b.1) - a.2.min(b.2) <= margin;
    let partners = |x: &Span, others: &[Span]| -> Vec<Span> {
        let mut found: Vec<Span> = others.iter().filter(|o| overlap(x, o)).copied().collect();
        found.sort_by(|u, v| u.1.total_cmp(&v.1).then(u.0.cmp(&v.0)));
        found
    };
    let at = |line: usize, segment: usize, lo: u32| check::Window {
        line: line as u32,
        segment: segment as u32,
        lo,
    };
    let (sp, sq) = (spans(p), spans(q));
    let of_q: Vec<Vec<Span>> = sq.iter().map(|b| partners(b, &sp)).collect();
    for a in &sp {
        let of_a = partners(a, &sq);
        for (ja, b) in of_a.iter().enumerate() {
            let kb = sq.iter().position(|s| s.0 == b.0).expect("a span of q");
            let jb = of_q[kb]
                .iter()
                .position(|s| s.0 == a.0)
                .expect("overlap is symmetric");
            let (lo, hi) = (a.1.max(b.1) - margin, a.2.min(b.2) + margin);
            let (a_lo, a_open, a_hi) = share(&of_a, ja);
            let (b_lo, b_open, b_hi) = share(&of_q[kb], jb);
            let (sa, sb) = (&lines[p][a.0], &lines[q][b.0]);
            let (wa, wa_lo) = clip(sa, t, lo.max(a_lo), a_open && a_lo >= lo, hi.min(a_hi));
            let (wb, wb_lo) = clip(sb, t, lo.max(b_lo), b_open && b_lo >= lo, hi.min(b_hi));
            if !wa.is_empty() && !wb.is_empty() && wa.len() + wb.len() >= 3 {
                out.push(Task {
                    a: wa,
                    b: wb,
                    a_at: at(p, a.0, wa_lo),
                    b_at: at(q, b.0, wb_lo),
                    line: p,
                });
            }
        }
    }
}

/// One triangulated strip.
struct Solved {
    /// Its path cost.
    cost: f64,
    /// Twice the planar signed area of its triangles (for the orientation of the mesh).
    signed_area: f64,
    /// Its part of the planar check, when the check runs locally.
    summary: Option<check::Summary>,
}

/// Triangulates one strip of `points` as `normalizer` maps them (into the unit box) into
/// `out` ([`triangles_of`] entries, in the orientation of `fuchs::path_triangles`); `uv`
/// are the planar positions (for its signed area); `interior` the strip's interior ranges
/// when the planar check runs locally.
#[allow(clippy::too_many_arguments)]
fn solve(
    points: &[DVec3],
    normalizer: &Normalizer,
    uv: &[[f64; 2]],
    task: &Task,
    params: &StripParams,
    weight: Weight,
    interior: Option<&[Vec<std::ops::Range<u32>>; 2]>,
    out: &mut [[u32; 3]],
) -> Result<Solved> {
    let unit = |ids: &[u32]| -> Vec<DVec3> {
        ids.iter()
            .map(|&k| normalizer.apply(points[k as usize]))
            .collect()
    };
    let (a, b) = (unit(&task.a), unit(&task.b));
    let solution = match params.method {
        Method::ShortestPath(solver) => shortest_path(&a, &b, weight, solver)?,
        Method::Lookahead(alpha) => lookahead(&a, &b, weight, alpha)?,
    };
    path_triangles_into(&solution.path, &task.a, &task.b, out)?;
    let summary = interior.map(|r| check::summarize(uv, task, &solution.path, r));
    let signed_area = out
        .iter()
        .map(|t| {
            let [p, q, r] = t.map(|k| uv[k as usize]);
            (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])
        })
        .sum();
    Ok(Solved {
        cost: solution.cost,
        signed_area,
        summary,
    })
}

/// How many triangles the strip of `task` has: one per step of its path,
/// |a| + |b| − 2. O(1).
fn triangles_of(task: &Task) -> usize {
    (task.a.len() + task.b.len()).saturating_sub(2)
}

/// Where a planar point lies in a counter-clockwise triangle.
enum Location {
    Outside,
    Inside,
    /// On the edge from corner k to corner k + 1.
    OnEdge(usize),
    /// On a corner (coincides in the plane with a vertex).
    OnVertex,
}

fn locate(uv: &[[f64; 2]], t: [u32; 3], p: [f64; 2]) -> Location {
    let o = [0, 1, 2].map(|k| orient2d(uv[t[k] as usize], uv[t[(k + 1) % 3] as usize], p));
    if o.iter().any(|&x| x < 0.0) {
        return Location::Outside;
    }
    match o.iter().filter(|&&x| x == 0.0).count() {
        0 => Location::Inside,
        1 => Location::OnEdge(o.iter().position(|&x| x == 0.0).expect("one zero")),
        _ => Location::OnVertex,
    }
}

/// Inserts lone point `x` into the first of `candidates` that contains it in the plane:
/// a triangle splits in three, an edge splits its one or two triangles in two. New
/// triangles are appended to `tris` and to `created`. Returns whether `x` was inserted.
/// O(candidates), plus O(m) to find the far side of an edge.
fn insert(
    uv: &[[f64; 2]],
    tris: &mut Vec<[u32; 3]>,
    candidates: impl Iterator<Item = usize>,
    created: &mut Vec<usize>,
    x: u32,
) -> bool {
    let p = uv[x as usize];
    for c in candidates {
        let t = tris[c];
        match locate(uv, t, p) {
            Location::Outside => continue,
            Location::OnVertex => return false,
            Location::Inside => {
                let [a, b, d] = t;
                tris[c] = [a, b, x];
                tris.push([b, d, x]);
                tris.push([d, a, x]);
                created.extend([tris.len() - 2, tris.len() - 1]);
                return true;
            }
            Location::OnEdge(k) => {
                let (u, v, w) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
                tris[c] = [u, x, w];
                tris.push([x, v, w]);
                created.push(tris.len() - 1);
                // The triangle on the other side of u→v, if any, has the edge v→u.
                let far = tris
                    .iter()
                    .position(|s| (0..3).any(|j| s[j] == v && s[(j + 1) % 3] == u));
                if let Some(f) = far {
                    let s = tris[f];
                    let j = (0..3).find(|&j| s[j] == v).expect("found above");
                    let z = s[(j + 2) % 3];
                    tris[f] = [v, x, z];
                    tris.push([x, u, z]);
                    created.push(tris.len() - 1);
                }
                return true;
            }
        }
    }
    false
}

/// Stitches strips between consecutive scan lines into one mesh over `points` (3-D, for
/// the path weights) with planar positions `uv` (for clipping, orientation and the check).
///
/// Time: detection of overlaps O(n + Σ segment pairs); each strip as its method (banded
/// shortest path O((n_a + n_b) · w), look-ahead O((n_a + n_b) · α²)), all strips in
/// parallel; lone points O(strip size) each; the check O(n) in parallel when it can be
/// decided from the strips (see `strips/check.rs`), else O(m α(m)) on the half-edge mesh.
/// Errors: `points` and `uv` of different lengths, a non-finite coordinate, bad
/// parameters.
pub fn stitch(
    points: &[DVec3],
    uv: &[[f64; 2]],
    scan: &ScanLines,
    params: &StripParams,
) -> Result<StripMesh> {
    stitch_with(points, uv, scan, params, true, None, &Progress::new()).map(|(mesh, _, _)| mesh)
}

/// The whole strip method from a line id per point, over some consecutive lines of a
/// larger scan as that scan's `context` makes them (`None`: these points are the whole
/// scan): the scan lines ([`crate::strips::lines::segment_lines`], split at gaps of
/// `gap_factor` median steps, and at depth jumps by `crate::strips::lines::split_at_jumps`
/// with `params.jump_factor`), then [`stitch`]. Returns the mesh and the (dropped point,
/// point it coincides with) pairs the lines found; the lines themselves are dropped before
/// returning, so they never live beside the caller's copy of the faces.
///
/// With a `context`, the triangles are the whole scan's strips between these lines, in
/// these points' indices, except that they are turned counter-clockwise by their own
/// [`StripMesh::signed_area`], not by the whole scan's, and that what is dropped at depth
/// jumps and overlaps is decided from these lines' triangles alone. Time and errors: those
/// of the two stages.
pub fn stitch_part(
    points: &[DVec3],
    uv: &[[f64; 2]],
    line_ids: &[i64],
    gap_factor: f64,
    params: &StripParams,
    context: Option<&ScanContext>,
    progress: &Progress,
) -> Result<(StripMesh, Vec<(u32, u32)>)> {
    crate::budget::check_stage(
        || format!("strips on {} points", uv.len()),
        PEAK_BYTES_PER_POINT.saturating_mul(uv.len() as u64),
    )?;
    let median = context.map(|c| c.median_step);
    let mut scan = crate::strips::lines::segment_lines_at(uv, line_ids, gap_factor, median)?;
    check_jump_factor(params.jump_factor)?;
    if points.len() == uv.len() {
        crate::strips::lines::split_at_jumps(&mut scan, points, uv, params.jump_factor)?;
    }
    let (mesh, _, _) = stitch_with(points, uv, &scan, params, true, context, progress)?;
    Ok((mesh, scan.duplicates))
}

/// Why the stitched mesh is not a valid planar triangulation, by the global check
/// ([`HalfEdgeMesh::from_triangles`] and [`HalfEdgeMesh::validate`] on the unit-box
/// positions `uv`): the oracle of the local check, and what names its errors. O(m α(m)).
fn global_check(n_points: usize, triangles: &[[u32; 3]], uv: &[[f64; 2]]) -> Option<Error> {
    HalfEdgeMesh::from_triangles(n_points, triangles)
        .and_then(|m| m.validate(uv))
        .err()
}

/// [`stitch`], deciding the planar check from the strips when `local` and it can (else,
/// and always when not `local`, by [`global_check`], and repairing what it refuses); also
/// returns the local verdict (`Some(true)` = accepted without the global check,
/// `Some(false)` = referred to it, `None` = not asked) and the global check's error before
/// the repair, for the tests that hold them against each other.
fn stitch_with(
    points: &[DVec3],
    uv: &[[f64; 2]],
    scan: &ScanLines,
    params: &StripParams,
    local: bool,
    context: Option<&ScanContext>,
    progress: &Progress,
) -> Result<(StripMesh, Option<bool>, Option<Error>)> {
    check_inputs(points, uv, scan, params)?;
    let caller_uv = uv;
    let unit = UnitFrame::new(points, uv, scan, params, context);
    let uv = &unit.uv[..];
    let (kept, oriented) = orient_lines(uv, scan, context)?;
    let tasks: Vec<Task> = kept
        .par_windows(2)
        .flat_map_iter(|pair| {
            let mut out = Vec::new();
            pair_tasks(uv, &oriented, pair[0], pair[1], unit.margin, &mut out);
            out
        })
        .collect();
    let plan = if params.check && local {
        check::plan(&tasks, &oriented, points.len())?
    } else {
        None
    };
    let Strips {
        mut triangles,
        ranges,
        solved,
    } = solve_strips(points, &unit, &tasks, params, plan.as_ref(), progress)?;
    let summaries: Vec<check::Summary> = solved.iter().filter_map(|s| s.summary).collect();
    let own = Own(context.and_then(|c| c.own_rows));
    // Sums in task order, over the strips returned.
    let (mut cost, mut signed_area, mut n_strips) = (0.0, 0.0, 0);
    for (task, s) in tasks.iter().zip(&solved) {
        if own.task(task) {
            cost += s.cost;
            signed_area += s.signed_area;
            n_strips += 1;
        }
    }
    // One orientation for the whole mesh: counter-clockwise in the plane where most of the
    // area is (all of it, unless lines cross).
    if signed_area < 0.0 {
        triangles.par_iter_mut().for_each(|t| t.swap(1, 2));
    }
    let inserted = insert_lone_points(uv, scan, &kept, &tasks, &ranges, &mut triangles);
    // Which points the strips use, before anything is dropped: a point all of whose
    // triangles are dropped is trimmed, not unused.
    let used_by_strips = used_points(points.len(), &triangles)?;
    let own_before = own.count(&triangles);
    let dropped_jumps = drop_jumps(points, caller_uv, uv, params.jump_factor, &mut triangles)?;
    let own_after_jumps = own.count(&triangles);
    // Lone points' triangles and dropped triangles are not strips: then only the global
    // check knows.
    let verdict = plan
        .as_ref()
        .map(|p| !inserted && dropped_jumps == 0 && p.accepts(&summaries, signed_area < 0.0));
    let first_error = if !params.check || verdict == Some(true) {
        None
    } else {
        global_check(points.len(), &triangles, uv)
    };
    let mut dropped_overlaps = 0;
    let planar_error = if first_error.is_some() {
        let before = triangles.len();
        triangles = repair::repair(uv, triangles)?;
        dropped_overlaps = before - triangles.len();
        global_check(points.len(), &triangles, uv)
    } else {
        None
    };
    let (mut unused, mut trimmed) = unused_and_trimmed(
        points.len(),
        &triangles,
        &used_by_strips,
        dropped_jumps + dropped_overlaps > 0,
    )?;
    if let Own(Some((lo, hi))) = own {
        let inside = |k: &u32| (lo..hi).contains(&(*k as usize));
        triangles.retain(|t| t.iter().all(inside));
        unused.retain(inside);
        trimmed.retain(inside);
    }
    let mesh = StripMesh {
        dropped_jumps: own_before.map_or(dropped_jumps, |b| b - own_after_jumps.unwrap_or(b)),
        dropped_overlaps: own_after_jumps.map_or(dropped_overlaps, |a| a - triangles.len()),
        triangles,
        unused,
        n_strips,
        cost,
        planar_error,
        trimmed,
        signed_area,
    };
    let asked = params.check && local;
    Ok((mesh, asked.then_some(verdict == Some(true)), first_error))
}

/// The rows whose strips a partition returns ([`ScanContext::own_rows`]); `None`: all.
#[derive(Clone, Copy)]
struct Own(Option<(usize, usize)>);

impl Own {
    /// Whether `task` is a strip between lines within the rows. O(1).
    fn task(&self, task: &Task) -> bool {
        let Own(Some((lo, hi))) = *self else {
            return true;
        };
        let first = |s: &[u32]| s.first().map_or(lo, |&k| k as usize);
        (lo..hi).contains(&first(&task.a)) && (lo..hi).contains(&first(&task.b))
    }

    /// How many `triangles` lie within the rows; `None` when all are returned. O(m).
    fn count(&self, triangles: &[[u32; 3]]) -> Option<usize> {
        let Own(Some((lo, hi))) = *self else {
            return None;
        };
        let inside = |t: &&[u32; 3]| t.iter().all(|&k| (lo..hi).contains(&(k as usize)));
        Some(triangles.par_iter().filter(inside).count())
    }
}

/// The checks of [`stitch_with`]'s input: one planar position per point, finite points,
/// a valid weight, jump factor and look-ahead depth, line indices that name given points.
/// O(n) in parallel; the serial pass that names the first bad point only on failure.
fn check_inputs(
    points: &[DVec3],
    uv: &[[f64; 2]],
    scan: &ScanLines,
    params: &StripParams,
) -> Result<()> {
    if points.len() != uv.len() {
        return Err(Error::InvalidParameter {
            name: "uv",
            value: format!("{} planar points for {} points", uv.len(), points.len()),
            expected: "one planar position per point",
        });
    }
    // The common case (all finite) in parallel; the serial check names the first bad one.
    if !points.par_iter().with_min_len(BLOCK).all(|p| p.is_finite()) {
        check_finite(points)?;
    }
    params.weight.check()?;
    check_jump_factor(params.jump_factor)?;
    if let Method::Lookahead(0) = params.method {
        return Err(Error::InvalidParameter {
            name: "alpha",
            value: "0".into(),
            expected: "alpha >= 1",
        });
    }
    if let Some(k) = scan
        .lines
        .par_iter()
        .flat_map_iter(|line| line.iter().flatten().copied())
        .find_first(|&k| k as usize >= points.len())
    {
        return Err(Error::InvalidParameter {
            name: "lines",
            value: format!("point index {k}"),
            expected: "indices of the given points",
        });
    }
    Ok(())
}

/// The unit box the strips are solved in: the 3-D map (applied as each strip copies its
/// points), the planar positions scaled by a power of two, the weight made scale-free and
/// the overlap margin in planar unit-box lengths.
struct UnitFrame {
    /// Maps the 3-D points into the unit box (one translation and uniform scale).
    normalizer: Normalizer,
    /// The planar positions, scaled into the unit square.
    uv: Vec<[f64; 2]>,
    /// `params.weight` with lengths in median steps and areas in squared median steps.
    weight: Weight,
    /// Half the scan's gap, in unit-square lengths (see [`pair_tasks`]).
    margin: f64,
}

impl UnitFrame {
    /// Work on positions mapped into the unit box (3-D and planar, each by one translation
    /// and uniform scale), so that path weights and planar products neither overflow at
    /// 1e300 nor underflow at 1e-300; the scan's step and gap follow the planar scale. The
    /// 3-D points are mapped as each strip copies them (no mapped copy of all of them).
    /// O(n) in parallel.
    fn new(
        points: &[DVec3],
        uv: &[[f64; 2]],
        scan: &ScanLines,
        params: &StripParams,
        context: Option<&ScanContext>,
    ) -> UnitFrame {
        // The bounding box in parallel; the fit of its two corners is the fit of all points.
        let normalizer = Normalizer::fit(&context.map_or_else(
            || {
                points
                    .par_iter()
                    .with_min_len(BLOCK)
                    .map(|&p| (p, p))
                    .reduce_with(|(lo, hi), (p, q)| (lo.min(p), hi.max(q)))
                    .map_or(Vec::new(), |(lo, hi)| vec![lo, hi])
            },
            |c| c.bounds.to_vec(),
        ));
        let to_unit_3d = if normalizer.half_extent > 0.0 {
            1.0 / normalizer.half_extent
        } else {
            1.0
        };
        // Scaled by a power of two, not moved: exact, so points collinear in the caller's
        // plane stay collinear and the planar check refuses their zero-area triangles, as
        // `mesh::validate` does (a shift would round them apart).
        let (unit_uv, to_unit_2d) = match context {
            Some(c) => unit_square_scaled_by(uv, c.largest_planar),
            None => unit_square_scaled(uv),
        };
        // Scale-free weights: lengths in median steps, areas in squared median steps. The
        // median step is planar; 3-D lengths are in the 3-D unit box.
        let h = if scan.median_step > 0.0 && (scan.median_step * to_unit_3d).is_normal() {
            scan.median_step * to_unit_3d
        } else {
            1.0
        };
        let w = params.weight;
        let weight = Weight {
            length: w.length / h + TIE_BREAK,
            area: w.area / (h * h),
            ..w
        };
        let margin = 0.5 * scan.gap * to_unit_2d.0 * to_unit_2d.1;
        UnitFrame {
            normalizer,
            uv: unit_uv,
            weight,
            margin,
        }
    }
}

/// A scan line: its segments, each its point indices.
type Line = Vec<Vec<u32>>;

/// The lines with a segment of at least two points (ascending), and every line oriented
/// alike (a zig-zag scan's every other line turned round; lines not kept left empty), so a
/// line's edges run one way in the strip before it and the other way in the strip after
/// it: the strips then fit together with one consistent orientation, whatever the plane.
/// Which lines turn round is a serial walk over the chords; the copies are parallel. Errors:
/// an [`Error::OutOfMemory`] for the oriented lines. O(n).
fn orient_lines(
    uv: &[[f64; 2]],
    scan: &ScanLines,
    context: Option<&ScanContext>,
) -> Result<(Vec<usize>, Vec<Line>)> {
    let kept: Vec<usize> = (0..scan.lines.len())
        .filter(|&l| scan.lines[l].iter().any(|s| s.len() >= 2))
        .collect();
    let mut turned = vec![false; scan.lines.len()];
    let mut previous: Option<[f64; 2]> = None;
    let first_turned = context.is_some_and(|c| c.first_turned);
    for &l in &kept {
        let mut c = chord(uv, &scan.lines[l]);
        let against = match previous {
            Some(p) => p[0] * c[0] + p[1] * c[1] < 0.0,
            None => first_turned,
        };
        if against {
            turned[l] = true;
            c = [-c[0], -c[1]];
        }
        previous = Some(c);
    }
    let oriented = (0..scan.lines.len()).into_par_iter().map(|l| {
        if kept.binary_search(&l).is_err() {
            return Vec::new();
        }
        let mut line = scan.lines[l].clone();
        if turned[l] {
            line.reverse();
            line.iter_mut().for_each(|s| s.reverse());
        }
        line
    });
    let oriented = try_par_collect("the oriented lines", oriented)?;
    Ok((kept, oriented))
}

/// The strips' triangles in one list, the range of each task in it, and each strip's
/// result (see [`solve_strips`]).
struct Strips {
    triangles: Vec<[u32; 3]>,
    ranges: Vec<std::ops::Range<usize>>,
    solved: Vec<Solved>,
}

/// Every strip solved in parallel, each writing its own range of the one triangle list (a
/// triangle per path step): the list, the range of each task (to find the strips around a
/// lone point) and each strip's result. Time: each strip as its method; errors: a strip's,
/// and an [`Error::OutOfMemory`] for the list.
fn solve_strips(
    points: &[DVec3],
    unit: &UnitFrame,
    tasks: &[Task],
    params: &StripParams,
    plan: Option<&check::Plan>,
    progress: &Progress,
) -> Result<Strips> {
    const WHAT: &str = "the strips' triangles";
    let mut ranges = try_vec(WHAT, tasks.len())?;
    let mut total = 0;
    for task in tasks {
        let count = triangles_of(task);
        ranges.push(total..total + count);
        total += count;
    }
    progress.plan(total as u64);
    let mut triangles = try_filled(WHAT, [0u32; 3], total)?;
    let mut parts = try_vec(WHAT, tasks.len())?;
    let mut rest = &mut triangles[..];
    for range in &ranges {
        let (part, tail) = rest.split_at_mut(range.len());
        parts.push(part);
        rest = tail;
    }
    // Everything per strip happens here, in parallel: what stays serial afterwards (lone
    // points) is memory traffic of a few ms per million.
    let solved: Vec<Solved> = tasks
        .par_iter()
        .zip(parts)
        .enumerate()
        .map(|(k, (task, out))| {
            let interior = plan.map(|p| p.interior(k));
            let count = out.len() as u64;
            let solved = solve(
                points,
                &unit.normalizer,
                &unit.uv,
                task,
                params,
                unit.weight,
                interior,
                out,
            );
            progress.add(count); // a strip is hundreds of points: an add apiece is cheap
            solved
        })
        .collect::<Result<_>>()?;
    Ok(Strips {
        triangles,
        ranges,
        solved,
    })
}

/// Lone points (one-point segments, and every point of lines passed over) inserted into
/// the triangles of the strips around their line (`kept` lines, `tasks` and their triangle
/// `ranges`) or into triangles made by earlier insertions. True when any was inserted.
/// O(strip size) per point.
fn insert_lone_points(
    uv: &[[f64; 2]],
    scan: &ScanLines,
    kept: &[usize],
    tasks: &[Task],
    ranges: &[std::ops::Range<usize>],
    triangles: &mut Vec<[u32; 3]>,
) -> bool {
    let mut created = Vec::new();
    let mut inserted = false;
    for (l, line) in scan.lines.iter().enumerate() {
        // The strips around line l start at the kept line before it, or at l itself.
        let before = kept
            .partition_point(|&k| k < l)
            .checked_sub(1)
            .map_or(l, |i| kept[i]);
        let first = tasks.partition_point(|t| t.line < before);
        let last = tasks.partition_point(|t| t.line <= l);
        for segment in line.iter().filter(|s| s.len() == 1) {
            let candidates: Vec<usize> = ranges[first..last]
                .iter()
                .flat_map(|r| r.clone())
                .chain(created.iter().copied())
                .collect();
            inserted |= insert(
                uv,
                triangles,
                candidates.into_iter(),
                &mut created,
                segment[0],
            );
        }
    }
    inserted
}

/// Depth jumps: triangles that still bridge one (a strip between a line on top of a wall
/// and one below it, parallel to the wall) are dropped, by the rule trimming uses (not its
/// gap rule: it would drop lookahead's long fans on clean grids), and so are the smaller
/// fans of the pinches that leaves (else the planar check would refuse them as a
/// crossing). `caller_uv` for the rule, the unit-square `uv` for the peeling. Returns how
/// many triangles were dropped; none with an infinite `factor`. O(m log m). Errors as
/// [`jumps::bridging`].
fn drop_jumps(
    points: &[DVec3],
    caller_uv: &[[f64; 2]],
    uv: &[[f64; 2]],
    factor: f64,
    triangles: &mut Vec<[u32; 3]>,
) -> Result<usize> {
    if !factor.is_finite() || triangles.is_empty() {
        return Ok(0);
    }
    let jumps = DepthJumps {
        points,
        factor,
        gaps: false,
    };
    let bridges = jumps::bridging(caller_uv, triangles, jumps)?;
    if !bridges.iter().any(|&b| b) {
        return Ok(0);
    }
    let before = triangles.len();
    let mut kept = std::mem::take(triangles);
    let mut bridge = bridges.iter();
    kept.retain(|_| !*bridge.next().expect("a flag per triangle"));
    // Crossing lines (no half-edge mesh) are the repair's business afterwards.
    *triangles = crate::triangulate::trim::peel_or_keep(uv, kept)?;
    Ok(before - triangles.len())
}

/// The points no triangle uses (ascending), and, when triangles were `dropped`, those of
/// them that the strips used (`used_by_strips`): trimmed, not unused. Errors: an
/// [`Error::OutOfMemory`]. O(n + m) in parallel.
fn unused_and_trimmed(
    n: usize,
    triangles: &[[u32; 3]],
    used_by_strips: &[AtomicBool],
    dropped: bool,
) -> Result<(Vec<u32>, Vec<u32>)> {
    let after = dropped.then(|| used_points(n, triangles)).transpose()?;
    let used = after.as_deref().unwrap_or(used_by_strips);
    let (unused, trimmed) = rayon::join(
        || not_in(used, |_| true),
        || match after {
            Some(_) => not_in(used, |k| used_by_strips[k].load(Ordering::Relaxed)),
            None => Ok(Vec::new()),
        },
    );
    Ok((unused?, trimmed?))
}

/// What the per-point flags and lists are called in memory errors.
const POINTS: &str = "the points the strips use";

/// Which of `n` points the triangles use. O(n + m) in parallel; relaxed stores of `true`
/// in any order leave the same flags, so parallel is exact. Errors: an
/// [`Error::OutOfMemory`] for the flags.
fn used_points(n: usize, triangles: &[[u32; 3]]) -> Result<Vec<AtomicBool>> {
    let used = (0..n)
        .into_par_iter()
        .with_min_len(BLOCK)
        .map(|_| AtomicBool::new(false));
    let used = try_par_collect(POINTS, used)?;
    triangles.par_iter().with_min_len(BLOCK).for_each(|t| {
        for &k in t {
            used[k as usize].store(true, Ordering::Relaxed);
        }
    });
    Ok(used)
}

/// The points not `used` for which `also` holds, ascending, in a buffer that may fail to
/// allocate (an [`Error::OutOfMemory`]). O(n).
fn not_in(used: &[AtomicBool], also: impl Fn(usize) -> bool + Sync) -> Result<Vec<u32>> {
    try_indices(POINTS, 0..used.len() as u32, |k| {
        !used[k as usize].load(Ordering::Relaxed) && also(k as usize)
    })
}

#[cfg(test)]
mod tests;
