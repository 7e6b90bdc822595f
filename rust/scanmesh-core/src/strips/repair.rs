//! Making stitched strips a valid planar triangulation where they are not: where scan
//! lines cross or fold in the plane (a zig-zag, a scanner's overlapping passes), strips
//! overlap there, share edges three ways or turn clockwise, and no choice of paths inside
//! the strips can avoid it. The conflicting triangles are dropped instead, as few as the
//! greedy rule below finds, so the mesh returned is always manifold and planar-valid and
//! what was dropped is counted.
//!
//! Rule: triangles that are not strictly counter-clockwise in the plane are dropped; of the
//! others, every pair whose interiors overlap (exact `orient2d`: no edge of either
//! separates them) is a conflict, and the conflicting triangles are kept greedily, fewest
//! conflicts first (ties by index, so the result is reproducible), each unless it overlaps
//! one already kept; finally the pinches this leaves are resolved and degenerate boundary
//! triangles peeled ([`crate::triangulate::trim::peel`]). Triangles in no conflict are all kept.
//! Strictly counter-clockwise triangles without overlaps have each edge at most once per
//! side, so the half-edge mesh exists, and once pinches are gone it passes
//! [`crate::mesh::HalfEdgeMesh::validate`] (tested on crossing and folded scans).

use crate::budget::{try_collect, try_filled, try_grow, try_indices};
use crate::geometry::orient2d;
use crate::Result;

/// Whether the interiors of two strictly counter-clockwise triangles overlap in the plane:
/// no edge of either has all corners of the other on or right of its line (two convex
/// polygons with disjoint interiors are separated by a line through an edge of one). O(1).
fn overlap(uv: &[[f64; 2]], s: [u32; 3], t: [u32; 3]) -> bool {
    let separates = |a: [u32; 3], b: [u32; 3]| {
        (0..3).any(|k| {
            let (p, q) = (uv[a[k] as usize], uv[a[(k + 1) % 3] as usize]);
            b.iter().all(|&r| orient2d(p, q, uv[r as usize]) <= 0.0)
        })
    };
    !separates(s, t) && !separates(t, s)
}

/// The pairs (i < j) of `triangles` whose interiors overlap, found through a uniform grid
/// of about m cells over their bounding box: each pair is tested once, in the cell of the
/// lower-left corner of the intersection of its bounding boxes. O(m + Σ cells covered +
/// Σ occupancy² per cell).
fn overlapping_pairs(uv: &[[f64; 2]], triangles: &[[u32; 3]]) -> Result<Vec<(u32, u32)>> {
    let boxes = triangles.iter().map(|t| {
        let p = t.map(|k| uv[k as usize]);
        [
            p[0][0].min(p[1][0]).min(p[2][0]),
            p[0][1].min(p[1][1]).min(p[2][1]),
            p[0][0].max(p[1][0]).max(p[2][0]),
            p[0][1].max(p[1][1]).max(p[2][1]),
        ]
    });
    let boxes = try_collect(WHAT, boxes)?;
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for b in &boxes {
        lo = [lo[0].min(b[0]), lo[1].min(b[1])];
        hi = [hi[0].max(b[2]), hi[1].max(b[3])];
    }
    let side = ((triangles.len() as f64).sqrt().ceil() as usize).max(1);
    let size = [(hi[0] - lo[0]) / side as f64, (hi[1] - lo[1]) / side as f64];
    let cell = |x: f64, k: usize| -> usize {
        if size[k] > 0.0 {
            (((x - lo[k]) / size[k]) as usize).min(side - 1)
        } else {
            0
        }
    };
    let mut entries: Vec<(usize, u32)> = Vec::new();
    for (i, b) in boxes.iter().enumerate() {
        for cy in cell(b[1], 1)..=cell(b[3], 1) {
            for cx in cell(b[0], 0)..=cell(b[2], 0) {
                try_grow(WHAT, &mut entries, 1)?;
                entries.push((cy * side + cx, i as u32));
            }
        }
    }
    entries.sort_unstable();
    let mut pairs = Vec::new();
    for run in entries.chunk_by(|x, y| x.0 == y.0) {
        for (k, &(c, i)) in run.iter().enumerate() {
            for &(_, j) in &run[k + 1..] {
                let (a, b) = (boxes[i as usize], boxes[j as usize]);
                let corner = [a[0].max(b[0]), a[1].max(b[1])];
                let disjoint = corner[0] > a[2].min(b[2]) || corner[1] > a[3].min(b[3]);
                if disjoint || cell(corner[1], 1) * side + cell(corner[0], 0) != c {
                    continue;
                }
                if overlap(uv, triangles[i as usize], triangles[j as usize]) {
                    try_grow(WHAT, &mut pairs, 1)?;
                    pairs.push((i.min(j), i.max(j)));
                }
            }
        }
    }
    Ok(pairs)
}

/// What the repair's buffers are called in memory errors.
const WHAT: &str = "the overlap repair";

/// `triangles` (over the planar positions `uv`) with the triangles dropped that keep them
/// from being a valid planar triangulation, by the rule of the module documentation. The
/// caller counts the difference. Errors: an [`crate::Error::OutOfMemory`]. O(m log m)
/// plus the overlap search.
pub(super) fn repair(uv: &[[f64; 2]], mut triangles: Vec<[u32; 3]>) -> Result<Vec<[u32; 3]>> {
    // In place: the counter-clockwise triangles, in order.
    triangles.retain(|t| {
        let [a, b, c] = t.map(|k| uv[k as usize]);
        orient2d(a, b, c) > 0.0
    });
    let ccw = triangles;
    let pairs = overlapping_pairs(uv, &ccw)?;
    let mut conflicts: Vec<Vec<u32>> = try_filled(WHAT, Vec::new(), ccw.len())?;
    for &(i, j) in &pairs {
        conflicts[i as usize].push(j);
        conflicts[j as usize].push(i);
    }
    let mut order = try_indices(WHAT, 0..ccw.len() as u32, |i| {
        !conflicts[i as usize].is_empty()
    })?;
    order.sort_by_key(|&i| (conflicts[i as usize].len(), i));
    let mut keep = try_filled(WHAT, true, ccw.len())?;
    let mut decided = try_filled(WHAT, false, ccw.len())?;
    for &i in &order {
        keep[i as usize] = !conflicts[i as usize]
            .iter()
            .any(|&j| decided[j as usize] && keep[j as usize]);
        decided[i as usize] = true;
    }
    let mut kept = ccw;
    let mut flags = keep.iter();
    kept.retain(|_| *flags.next().expect("a flag per triangle"));
    // Without overlaps the half-edge mesh exists; should it not, the caller's check names
    // why, on the triangles as they are.
    crate::triangulate::trim::peel_or_keep(uv, kept)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Brute force: every pair tested.
    fn all_pairs(uv: &[[f64; 2]], triangles: &[[u32; 3]]) -> Vec<(u32, u32)> {
        let mut out = Vec::new();
        for i in 0..triangles.len() {
            for j in i + 1..triangles.len() {
                if overlap(uv, triangles[i], triangles[j]) {
                    out.push((i as u32, j as u32));
                }
            }
        }
        out
    }

    #[test]
    fn the_grid_finds_the_pairs_brute_force_finds() {
        use crate::testing::random_points;
        for round in 0..40u64 {
            let n = 8 + 3 * round as usize;
            let uv = random_points(n, round);
            // Random corners: two coordinates and one more of a second stream per triangle.
            let picks = random_points(n, 1000 + round);
            let pick = |x: f64| ((x * n as f64) as u32).min(n as u32 - 1);
            let tris: Vec<[u32; 3]> = picks
                .windows(2)
                .map(|w| [pick(w[0][0]), pick(w[0][1]), pick(w[1][0])])
                .filter(|t| {
                    let [a, b, c] = t.map(|k| uv[k as usize]);
                    orient2d(a, b, c) > 0.0
                })
                .collect();
            let mut grid = overlapping_pairs(&uv, &tris).unwrap();
            grid.sort_unstable();
            assert!(round < 5 || !grid.is_empty());
            assert_eq!(grid, all_pairs(&uv, &tris), "round {round}");
        }
    }

    #[test]
    fn overlap_is_about_interiors() {
        let uv = [
            [0.0, 0.0],
            [2.0, 0.0],
            [0.0, 2.0],
            [2.0, 2.0],
            [1.0, 0.5],
            [3.0, 3.0],
        ];
        // Sharing the edge 1-2 from opposite sides: no overlap.
        assert!(!overlap(&uv, [0, 1, 2], [1, 3, 2]));
        // A corner inside the other: overlap.
        assert!(overlap(&uv, [0, 1, 2], [4, 3, 2]));
        // Touching at a corner only.
        assert!(!overlap(&uv, [0, 1, 3], [3, 5, 2]));
        // The same triangle twice.
        assert!(overlap(&uv, [0, 1, 2], [1, 2, 0]));
    }
}
