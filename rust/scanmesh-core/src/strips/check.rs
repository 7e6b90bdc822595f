//! The planar check of a stitched mesh decided from its strips, without building the
//! half-edge mesh: a fast path for [`HalfEdgeMesh::validate`] that answers "valid" or
//! "ask the global check", never "invalid" on its own, so every error is still named by
//! the global check and the result of `stitch` cannot change.
//!
//! # Why the local check is equivalent to the global one
//!
//! A strip triangulates a window `a` (a contiguous slice of a segment of line p) against a
//! window `b` (of the next kept line q) along a monotone path: step A adds
//! (a_i, a_{i+1}, b_j), step B adds (a_i, b_{j+1}, b_j). So a strip is a disc whose
//! vertices all lie on its boundary cycle a_0 → … → a_{n−1} → b_{m−1} → … → b_0 → a_0: its
//! a-edges run forward, its b-edges backward, its rungs a_i–b_j (the path's nodes) are
//! shared by consecutive triangles, and the first and last rung by one triangle each. With
//! every line oriented alike, the edges of line q run backward in the strips below q (q's
//! windows as `b`, the "below" windows) and forward in the strips above it (the "above"
//! windows). Assume, as [`plan`] checks, (i) every point index occurs once in the scan
//! lines, (ii) the windows on one side of a line are pairwise disjoint, and (iii) a below
//! and an above window of one segment that meet share at least two points (an edge). Then:
//!
//! - *No repeated directed edge, no repeated vertex.* A triangle's vertices come from two
//!   lines, distinct by (i). A rung joins lines p and q, so only strips between p and q
//!   hold it, and of those only the one whose windows hold both ends: it is in one strip,
//!   used once each way. A line edge of q is used backward by at most one below window and
//!   forward by at most one above window (ii).
//! - *Twins.* A line edge is interior exactly when it lies in the intersection I of a below
//!   and an above window; rungs are interior except each strip's first and last.
//! - *One fan per vertex.* In one strip the triangles at a vertex are consecutive along the
//!   path (a fan). By (ii) a vertex of line q is in at most one below and one above window,
//!   so it has at most two fans, and where it has two they share a line edge (iii) and form
//!   one fan; that fan is closed exactly when v is strictly inside I (both of v's line
//!   edges are shared), and every other used vertex is on the boundary.
//! - *Winding.* For the global check's count ([`HalfEdgeMesh::validate`]'s `fan_winding`)
//!   an interior vertex's winding number is a sum over its corners of a 0/1 term (from the
//!   other two corners of the triangle); with every triangle strictly counter-clockwise
//!   (exact `orient2d`, checked per strip) each winding number is ≥ 1, so all of them are 1
//!   exactly when the terms summed over all interior corners equal the number of interior
//!   vertices. Each strip sums its own corners; the sums are added.
//! - *Euler.* V − E + F of one strip is n + m − (2(n + m) − 3) + (n + m − 2) = 1, and each
//!   intersection I takes |I| vertices and |I| − 1 edges off, so V − E + F = strips −
//!   intersections. Components are strips joined by intersections (a union-find over
//!   strips). Boundary loops follow the strips' boundary cycles with the shared edges cut
//!   out: each remaining run of a strip's cycle goes from one vertex to another, and at a
//!   boundary vertex exactly one boundary half-edge leaves (one fan), the run starting
//!   there; counting the cycles of "the run starting where this one ends" counts the loops
//!   the global check walks half-edge by half-edge.
//!
//! So under (i)-(iii) the mesh passes every check of [`HalfEdgeMesh::from_triangles`] and
//! [`HalfEdgeMesh::validate`] exactly when all its triangles are strictly
//! counter-clockwise, the winding sum matches and the Euler characteristic matches, which
//! is what [`Plan::accepts`] tests. When (i)-(iii) fail, or lone points were inserted
//! (their triangles are not strips), the caller runs the global check. A below and an
//! above window meeting in one point is always a pinch (two fans sharing no edge), and two
//! windows of one side sharing an edge a repeated directed edge, so the global check
//! refuses those too; two windows of one side touching in one point can be valid (another
//! window may join their fans), which only the global check decides. Tested against the
//! global check on random and adversarial scans (`strips::tests`).
//!
//! [`HalfEdgeMesh::validate`]: crate::mesh::HalfEdgeMesh::validate
//! [`HalfEdgeMesh::from_triangles`]: crate::mesh::HalfEdgeMesh::from_triangles

use super::{Task, BLOCK};
use crate::budget::{try_collect, try_filled, try_par_collect, try_vec};
use crate::geometry::orient2d;
use crate::mesh::count_cycles;
use crate::strips::fuchs::Step;
use crate::Result;
use rayon::prelude::*;
use std::collections::HashMap;
use std::ops::Range;
use std::sync::atomic::{AtomicBool, Ordering};

/// Where a strip's window lies: segment `segment` of line `line`, from point `lo` of it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub(super) struct Window {
    /// Index of the line in the scan.
    pub line: u32,
    /// Index of the segment in its line.
    pub segment: u32,
    /// Index in the segment of the window's first point.
    pub lo: u32,
}

/// What the strips' windows decide before any strip is solved: the topology (checked
/// here) and which window points are interior vertices (for the winding sums).
pub(super) struct Plan {
    /// Per task, per side (a, b): window-local index ranges of interior vertices.
    interior: Vec<[Vec<Range<u32>>; 2]>,
    /// Number of interior vertices of the whole mesh.
    interior_count: u64,
}

/// A window as an interval of its segment, for the sweeps of [`plan`].
#[derive(Clone, Copy)]
struct Span {
    key: (u32, u32),
    lo: u32,
    /// Last point, inclusive.
    hi: u32,
    task: usize,
}

/// The mesh's topology from the strips' windows, or `None` when the module's conditions
/// (i)-(iii) fail or the Euler characteristic does not match (then only the global check
/// can name the fault). `lines` are the scan's lines (for condition (i)), `n_points` the
/// number of points. Errors: an [`crate::Error::OutOfMemory`] for its buffers. O(n) for
/// (i) (parallel), O(s log s) for s strips otherwise.
pub(super) fn plan(
    tasks: &[Task],
    lines: &[Vec<Vec<u32>>],
    n_points: usize,
) -> Result<Option<Plan>> {
    const WHAT: &str = "the strips' planar check";
    let seen = (0..n_points)
        .into_par_iter()
        .with_min_len(BLOCK)
        .map(|_| AtomicBool::new(false));
    let seen = try_par_collect(WHAT, seen)?;
    let distinct = lines.par_iter().all(|line| {
        line.iter()
            .flatten()
            .all(|&k| !seen[k as usize].swap(true, Ordering::Relaxed))
    });
    if !distinct {
        return Ok(None);
    }
    drop(seen);
    // Windows by segment: side 0 = above (tasks' a), side 1 = below (tasks' b).
    let mut sides: [Vec<Span>; 2] = [try_vec(WHAT, tasks.len())?, try_vec(WHAT, tasks.len())?];
    for (k, t) in tasks.iter().enumerate() {
        for (side, (w, len)) in [(t.a_at, t.a.len()), (t.b_at, t.b.len())]
            .into_iter()
            .enumerate()
        {
            sides[side].push(Span {
                key: (w.line, w.segment),
                lo: w.lo,
                hi: w.lo + len as u32 - 1,
                task: k,
            });
        }
    }
    for spans in &mut sides {
        spans.sort_unstable_by_key(|s| (s.key, s.lo));
        // (ii): windows of one side of a segment pairwise disjoint.
        if spans
            .windows(2)
            .any(|w| w[0].key == w[1].key && w[0].hi >= w[1].lo)
        {
            return Ok(None);
        }
    }
    // Intersections of above and below windows: a merge of the two sorted lists.
    let mut shared: Vec<[Vec<(u32, u32)>; 2]> = try_filled(WHAT, Default::default(), tasks.len())?;
    let mut parent = try_collect(WHAT, 0..tasks.len())?;
    fn root(parent: &mut [usize], mut x: usize) -> usize {
        while parent[x] != x {
            parent[x] = parent[parent[x]];
            x = parent[x];
        }
        x
    }
    let (above, below) = (&sides[0], &sides[1]);
    let (mut i, mut j) = (0, 0);
    let mut intersections = 0i64;
    let mut interior_count = 0u64;
    while i < above.len() && j < below.len() {
        let (x, y) = (above[i], below[j]);
        if (x.key, x.hi) < (y.key, y.lo) {
            i += 1;
            continue;
        }
        if (y.key, y.hi) < (x.key, x.lo) {
            j += 1;
            continue;
        }
        // Same segment, overlapping.
        let (lo, hi) = (x.lo.max(y.lo), x.hi.min(y.hi));
        if lo == hi {
            return Ok(None); // (iii): a pinch, refused by the global check
        }
        intersections += 1;
        interior_count += u64::from(hi - lo - 1);
        shared[x.task][0].push((lo - x.lo, hi - x.lo));
        shared[y.task][1].push((lo - y.lo, hi - y.lo));
        let (rx, ry) = (root(&mut parent, x.task), root(&mut parent, y.task));
        parent[rx.max(ry)] = rx.min(ry);
        if x.hi < y.hi {
            i += 1;
        } else {
            j += 1;
        }
    }
    let components = (0..tasks.len())
        .filter(|&k| root(&mut parent, k) == k)
        .count() as i64;
    let Some(loops) = boundary_loops(tasks, &shared) else {
        return Ok(None);
    };
    if tasks.len() as i64 - intersections != 2 * components - loops {
        return Ok(None);
    }
    let interior = shared
        .into_iter()
        .map(|s| s.map(|v| v.into_iter().map(|(lo, hi)| lo + 1..hi).collect()));
    let interior = try_collect(WHAT, interior)?;
    Ok(Some(Plan {
        interior,
        interior_count,
    }))
}

/// Boundary loops of the mesh: the cycles of the map "run of a strip's boundary cycle
/// (shared edges cut out) → the run starting where it ends". `shared[k]` = the window-local
/// intervals (first, last point) of strip k's a and b windows whose edges are shared.
/// `None` when a vertex starts two runs or ends a run that no run leaves (not one fan;
/// excluded by the module's conditions, kept as a guard). O(runs).
fn boundary_loops(tasks: &[Task], shared: &[[Vec<(u32, u32)>; 2]]) -> Option<i64> {
    // Positions on strip k's cycle: a_0..a_{n−1} are 0..n−1, b_{m−1}..b_0 are n..n+m−1;
    // edge p goes from position p to p + 1 (mod n + m).
    let mut loops = 0;
    let mut runs: Vec<(u32, u32)> = Vec::new(); // (start vertex, end vertex)
    let mut cut: Vec<(u32, u32)> = Vec::new();
    for (task, shared) in tasks.iter().zip(shared) {
        let (n, m) = (task.a.len() as u32, task.b.len() as u32);
        let vertex = |p: u32| {
            if p < n {
                task.a[p as usize]
            } else {
                task.b[(n + m - 1 - p) as usize]
            }
        };
        // Cut edges as position intervals [first edge, last edge]; never a rung.
        cut.clear();
        cut.extend(shared[0].iter().map(|&(lo, hi)| (lo, hi - 1)));
        cut.extend(
            shared[1]
                .iter()
                .map(|&(lo, hi)| (n + m - 1 - hi, n + m - 2 - lo)),
        );
        if cut.is_empty() {
            loops += 1; // the strip's whole cycle is a loop
            continue;
        }
        cut.sort_unstable();
        for (k, &(_, last)) in cut.iter().enumerate() {
            let next_first = cut[(k + 1) % cut.len()].0;
            runs.push((vertex(last + 1), vertex(next_first)));
        }
    }
    let mut starting: HashMap<u32, usize> = HashMap::with_capacity(runs.len());
    for (k, &(start, _)) in runs.iter().enumerate() {
        if starting.insert(start, k).is_some() {
            return None;
        }
    }
    let run_loops = count_cycles(runs.len(), |k| starting.get(&runs[k].1).copied())?;
    Some(loops + run_loops as i64)
}

/// What one strip contributes to the verdict of [`Plan::accepts`].
#[derive(Debug, Clone, Copy)]
pub(super) struct Summary {
    /// Every triangle is strictly counter-clockwise as built (exact).
    positive: bool,
    /// Every triangle is strictly clockwise as built (exact).
    negative: bool,
    /// Sum of the winding terms of the corners at interior vertices, with the triangles
    /// as built (0) and turned round (1).
    winding: [u64; 2],
}

impl Plan {
    /// The interior ranges of task `k`'s a and b windows, for [`summarize`]. O(1).
    pub(super) fn interior(&self, k: usize) -> &[Vec<Range<u32>>; 2] {
        &self.interior[k]
    }

    /// True when the mesh is a valid planar triangulation in the sense of
    /// [`crate::mesh::HalfEdgeMesh::validate`]: every triangle strictly counter-clockwise
    /// once the mesh is turned round (`flipped`) or not, and every interior fan winding
    /// once. False means "ask the global check". O(strips).
    pub(super) fn accepts(&self, summaries: &[Summary], flipped: bool) -> bool {
        let oriented = summaries
            .iter()
            .all(|s| if flipped { s.negative } else { s.positive });
        let winding: u64 = summaries
            .iter()
            .map(|s| s.winding[usize::from(flipped)])
            .sum();
        oriented && winding == self.interior_count
    }
}

/// The orientation and winding terms of the strip of `task` along `path`, with
/// `interior` = [`Plan::interior`] of its task and `uv` the planar positions. O(n + m).
pub(super) fn summarize(
    uv: &[[f64; 2]],
    task: &Task,
    path: &[Step],
    interior: &[Vec<Range<u32>>; 2],
) -> Summary {
    let mask = |len: usize, ranges: &[Range<u32>]| {
        let mut m = vec![false; len];
        for r in ranges {
            m[r.start as usize..r.end as usize].fill(true);
        }
        m
    };
    let inner = [
        mask(task.a.len(), &interior[0]),
        mask(task.b.len(), &interior[1]),
    ];
    let ids = [&task.a, &task.b];
    let mut summary = Summary {
        positive: true,
        negative: true,
        winding: [0, 0],
    };
    let (mut i, mut j) = (0usize, 0usize);
    for &s in path {
        // Corners as (side, window index), in the order `fuchs::path_triangles_into` writes them.
        let corners = match s {
            Step::A => [(0, i), (0, i + 1), (1, j)],
            Step::B => [(0, i), (1, j + 1), (1, j)],
        };
        match s {
            Step::A => i += 1,
            Step::B => j += 1,
        }
        let p = corners.map(|(side, k)| uv[ids[side][k] as usize]);
        let o = orient2d(p[0], p[1], p[2]);
        summary.positive &= o > 0.0;
        summary.negative &= o < 0.0;
        for (c, &(side, k)) in corners.iter().enumerate() {
            if !inner[side][k] {
                continue;
            }
            // `fan_winding`'s term for the corner at v: the half-edge leaving v ends at
            // the next corner, the one entering v starts at the previous corner.
            let v = p[c];
            let lower = |q: [f64; 2]| q[1] < v[1] || (q[1] == v[1] && q[0] < v[0]);
            let (next, before) = (lower(p[(c + 1) % 3]), lower(p[(c + 2) % 3]));
            summary.winding[0] += u64::from(next && !before);
            summary.winding[1] += u64::from(before && !next);
        }
    }
    summary
}
