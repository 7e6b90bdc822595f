//! Ears across the notches a slanted outline leaves in a range grid's cells
//! ([`fill_notches`]), where the outline is not concave (there an ear's chord between two
//! samples of the part leaves it: a bore's rim, an inner corner). Measured on
//! benches/curtains.py's range-scan panel (docs/benchmarks/curtains.md, "Notch ears").

use crate::budget::try_filled;
use crate::geometry::UnitSquare;
use crate::Result;
use rayon::prelude::*;
use std::collections::{HashMap, HashSet, VecDeque};

/// What the notch ears' failed allocations name.
const NOTCHES: &str = "the grid's notch ears";

/// Largest turn (degrees) of a notch-filling ear from the line of sight ([`fill_notches`]),
/// below θ: an ear is a guess between samples of the outline, not a cell whose rays
/// bracket it. On benches/curtains.py's panel the ears turned more raised the height error
/// far more than they filled missed area (figures in docs/benchmarks/curtains.md, "Figures
/// behind the core's constants").
pub const EAR_TURN_DEG: f64 = 60.0;

/// Boundary vertices walked beyond each end of a notch-filling ear's chord to see whether
/// the outline there is concave ([`fill_notches`], [`EAR_SAG`]).
pub const EAR_WINDOW: usize = 6;

/// Largest sag (local grid spacings) of the outline towards the mesh from the chord
/// between the boundary vertices [`EAR_WINDOW`] beyond an ear's ends ([`fill_notches`]).
/// A straight outline's staircase lies within about one spacing of that chord (its
/// vertices are samples within a cell of the outline); a concave one (a bore's rim, an
/// inner corner) sags further, and there an ear's chord leaves the part. 1.5: a half
/// spacing of margin, which keeps the rocker arm's rim ears out where 2 lets them through
/// (figures in docs/benchmarks/curtains.md, "Figures behind the core's constants").
pub const EAR_SAG: f64 = 1.5;

/// The sign of the planar area of (a, b, c): 1, -1, or 0 when degenerate (computed on the
/// edges scaled to about 1 by a power of two, exactly, so that no product overflows or
/// underflows).
pub(crate) fn area_sign(uv: &[[f64; 2]], a: usize, b: usize, c: usize) -> i8 {
    let (p, q, r) = (uv[a], uv[b], uv[c]);
    let e = [q[0] - p[0], q[1] - p[1], r[0] - p[0], r[1] - p[1]];
    let unit = UnitSquare::by(e.iter().fold(0.0f64, |m, x| m.max(x.abs())));
    let [ux, uy, vx, vy] = e.map(|x| unit.scale(x));
    let area = ux * vy - uy * vx;
    if area > 0.0 {
        1
    } else if area < 0.0 {
        -1
    } else {
        0
    }
}

/// The grid, for the samples of a block of rows and columns.
pub(crate) struct GridAt<'a> {
    pub(crate) grid: &'a [i64],
    pub(crate) rows: usize,
    pub(crate) cols: usize,
}

impl GridAt<'_> {
    /// The points in rows `r0..=r1` and columns `c0..=c1` (clipped to the grid).
    fn block(&self, [r0, r1]: [usize; 2], [c0, c1]: [usize; 2]) -> impl Iterator<Item = u32> + '_ {
        let (r1, c1) = (r1.min(self.rows - 1), c1.min(self.cols - 1));
        (r0..=r1)
            .flat_map(move |r| (c0..=c1).map(move |c| self.grid[r * self.cols + c]))
            .filter(|&g| g >= 0)
            .map(|g| g as u32)
    }
}

/// Triangles that fill the notches of the outline of the kept triangles (the candidates
/// `cands` flagged in `flags`, counter-clockwise in `uv`),
/// where an outline crossing the grid at a slant leaves a staircase. At each boundary
/// vertex v whose outline turns away from the mesh (u → v → w, the mesh on the left, a
/// right turn), the ear (u, w, v) outside it is added when
///
/// - it is **unimodular in the grid**: its corners' (row, column) span a parallelogram of
///   area 1, so no ray of the scanner's grid passes inside it, and no sample missing
///   there (a bore, a gap, a dropout) can lie under it;
/// - no sample lies inside or on it in the plane, and u-w is not an edge yet, so the
///   result stays a valid planar triangulation;
/// - `keep(ear, [row, column])` accepts it (the grid's edge rule at the cell of the ear's
///   lowest row and column, and a turn within [`EAR_TURN_DEG`]);
/// - the outline is **not concave** there: it sags towards the mesh at most [`EAR_SAG`]
///   × `step([row, column])` (the local spacing) from the chord between the boundary
///   vertices [`EAR_WINDOW`] beyond the ear's ends, and turns at most 90° between them
///   ([`sag`]). A notch of a straight or convex outline and a corner of a concave one look
///   alike (both free of lattice points), but only the former's chord stays on the part.
///
/// Repeated (first in, first out from the boundary vertices in ascending order) until no
/// ear is added, so a notch several cells long fills ear by ear; deterministic. `cands`
/// are the candidates before peeling with their `cells` and corner `codes`; `boundary` the
/// kept triangles' half-edges (3t + k from corner k) without a kept twin, ascending.
/// O(n + m + boundary x (block + window)), a block of (edge / spacing + 3)² samples: the
/// maps hold the boundary only, and the pass over all triangles (the edges beside the
/// boundary) indexes arrays on every core (looking every kept triangle's corners up in the
/// boundary's map took about a quarter of the core's samples under perf on the 1M-point
/// grid of benches/curtains.py's timing). Errs only when the n flags cannot be allocated.
pub(crate) fn fill_notches(
    grid: &GridAt,
    uv: &[[f64; 2]],
    (cands, cells, codes): (&[[u32; 3]], &[u32], &[[u8; 3]]),
    (flags, boundary): (&[bool], &[u32]),
    (keep, step): (
        impl Fn(&[u32; 3], [usize; 2]) -> bool,
        impl Fn([usize; 2]) -> f64,
    ),
) -> Result<Vec<[u32; 3]>> {
    // the boundary half-edges, a -> b with the mesh on the left, and the (row, column) of
    // their vertices
    let (mut next, mut prev, mut at) = (HashMap::new(), HashMap::new(), HashMap::new());
    // which samples start a boundary half-edge: next's keys, for the pass over the kept
    let mut starts = try_filled(NOTCHES, false, uv.len())?;
    for &h in boundary {
        let (t, k) = ((h / 3) as usize, (h % 3) as usize);
        let (a, b) = (cands[t][k], cands[t][(k + 1) % 3]);
        starts[a as usize] = true;
        next.insert(a, b);
        prev.insert(b, a);
        let cell = cells[t] as usize;
        let code = codes[t][k] as usize;
        let r = cell / (grid.cols - 1) + (code >> 1);
        at.insert(a, [r as i64, (cell % (grid.cols - 1) + (code & 1)) as i64]);
    }
    let key = |a: u32, b: u32| (a.min(b), a.max(b));
    // the edges of kept triangles at the boundary: an ear's chord must not be one
    let mut edges: HashSet<(u32, u32)> = (cands.par_iter().zip(flags))
        .with_min_len(1 << 14)
        .filter(|&(t, &kept)| kept && t.iter().any(|&v| starts[v as usize]))
        .flat_map_iter(|(t, _)| [key(t[0], t[1]), key(t[1], t[2]), key(t[2], t[0])])
        .collect();
    let mut queue: Vec<u32> = next.keys().copied().collect();
    queue.sort_unstable();
    let mut queue = VecDeque::from(queue);
    let mut out = Vec::new();
    while let Some(v) = queue.pop_front() {
        let (Some(&w), Some(&u)) = (next.get(&v), prev.get(&v)) else {
            continue;
        };
        let ear = [u, w, v];
        let turns_away = area_sign(uv, u as usize, w as usize, v as usize) == 1;
        if u == w || !turns_away || edges.contains(&key(u, w)) {
            continue;
        }
        let [pu, pw, pv] = ear.map(|k| at[&k]);
        let det = (pw[0] - pu[0]) * (pv[1] - pu[1]) - (pw[1] - pu[1]) * (pv[0] - pu[0]);
        if det.abs() != 1 {
            continue;
        }
        let lo = |i: usize| pu[i].min(pw[i]).min(pv[i]) as usize;
        let hi = |i: usize| pu[i].max(pw[i]).max(pv[i]) as usize + 1;
        let covers = |x: u32| {
            !ear.contains(&x)
                && (0..3).all(|k| {
                    area_sign(uv, ear[k] as usize, ear[(k + 1) % 3] as usize, x as usize) >= 0
                })
        };
        let block = [[lo(0).max(1) - 1, hi(0)], [lo(1).max(1) - 1, hi(1)]];
        if grid.block(block[0], block[1]).any(covers) || !keep(&ear, [lo(0), lo(1)]) {
            continue;
        }
        // where the outline is concave (a rim around a bore, an inner corner) the chord
        // between two samples of the part leaves it, though no ray lies under the ear
        if sag(uv, &next, &prev, [u, w], EAR_WINDOW) > EAR_SAG * step([lo(0), lo(1)]) {
            continue;
        }
        out.push(ear);
        edges.insert(key(u, w));
        if next.get(&w) == Some(&u) {
            // a boundary of three closes
            for x in ear {
                next.remove(&x);
                prev.remove(&x);
            }
        } else {
            next.remove(&v);
            prev.remove(&v);
            next.insert(u, w);
            prev.insert(w, u);
            queue.extend([u, w]);
        }
    }
    Ok(out)
}

/// How far (input units) the outline sags towards the mesh (to the left) from the chord
/// between the boundary vertices p, `window` steps before `u`, and q, `window` steps after
/// `w` (fewer where the boundary is shorter): the largest signed distance of the vertices
/// from p to q, or infinity when the outline turns more than 90° at one of them (the tip
/// of a spur). At most about a spacing on a straight outline's staircase, negative on a
/// convex one, more on a concave one (a bore of radius R seen over a chord of length l
/// sags l² / 8R). O(window).
fn sag(
    uv: &[[f64; 2]],
    next: &HashMap<u32, u32>,
    prev: &HashMap<u32, u32>,
    [u, w]: [u32; 2],
    window: usize,
) -> f64 {
    let (mut p, mut q) = (u, w);
    for _ in 0..window {
        match prev.get(&p) {
            Some(&x) if x != q => p = x,
            _ => break,
        }
        match next.get(&q) {
            Some(&x) if x != p => q = x,
            _ => break,
        }
    }
    let [a, b] = [p, q].map(|k| uv[k as usize]);
    let d = [b[0] - a[0], b[1] - a[1]];
    let length = d[0].hypot(d[1]);
    if length == 0.0 {
        return 0.0;
    }
    let mut worst = f64::NEG_INFINITY;
    let mut x = p;
    while x != q {
        let c = uv[x as usize];
        worst = worst.max((d[0] * (c[1] - a[1]) - d[1] * (c[0] - a[0])) / length);
        let (Some(&y), Some(&o)) = (next.get(&x), prev.get(&x)) else {
            break;
        };
        // a turn over 90° is the tip of a spur one or two samples thin (a rim between a
        // bore and a lower level): its outline has no direction to judge, and the ear
        // between it and the outline beside it cuts the corner of what the spur rims
        let [b, e] = [uv[o as usize], uv[y as usize]];
        if x != p && (c[0] - b[0]) * (e[0] - c[0]) + (c[1] - b[1]) * (e[1] - c[1]) < 0.0 {
            return f64::INFINITY;
        }
        x = y;
    }
    worst
}
