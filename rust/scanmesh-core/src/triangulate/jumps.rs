//! Depth jumps and gaps: triangles whose longest 3-D edge is steep and long against the
//! local 3-D spacing (a wall, a step, the rim of a bore), or long at any slope against the
//! spacing across lines, found in rounds until nothing more is dropped.

use crate::budget::{try_filled, try_indices, try_par_collect, try_vec};
use crate::geometry::planar_distance;
use crate::geometry::Normalizer;
use crate::mesh::Fans;
use crate::{Error, Result};
use glam::DVec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// Triangles (or vertices) per rayon task in the passes over all of them.
const BLOCK: usize = 1 << 14;

/// Default depth-jump factor: a triangle whose longest 3-D edge is steeper than 45° and
/// exceeds this multiple of the local 3-D spacing at its best-sampled corner (see
/// [`DepthJumps`]) bridges a wall, a step or a bore and is dropped. Chosen by
/// benches/depth_jumps.py on three CAD parts scanned along their axis: 3 removes most of
/// planar trimming's height error; 2 misses more of the shadow, 4 less of the fandisk's
/// at more height error (figures in docs/benchmarks/depth-jumps.md, "Figures behind the
/// core's constants").
pub const DEFAULT_JUMP_FACTOR: f64 = 3.0;

/// Default bridge factor: a triangle at any slope whose longest 3-D edge exceeds this
/// multiple of the spacing across lines at its best-sampled corner (see `Spacing`) spans
/// a gap the planar rules leave (a strip's rung across a missed stretch of the next line,
/// lookahead's fan from the end of a line segment, a sheet over a hole narrower than the
/// planar trim length) and is dropped with the depth jumps. Chosen on the scans of
/// benches/strips_geometry.py: 4 also drops lookahead's rungs on a clean jittered grid, 6
/// keeps some of its fans over the connecting rod's bore (figures in
/// docs/benchmarks/depth-jumps.md, "Figures behind the core's constants").
pub const DEFAULT_BRIDGE_FACTOR: f64 = 5.0;

/// The depth-jump rule of [`trim_long_edges`](crate::triangulate::trim::trim_long_edges): the 3-D
/// points (same indices as the planar
/// ones) and the factor (`∞` turns it off).
#[derive(Debug, Clone, Copy)]
pub struct DepthJumps<'a> {
    /// 3-D positions of the points.
    pub points: &'a [DVec3],
    /// A triangle is dropped when its longest 3-D edge is steep and exceeds `factor` times
    /// the smallest local spacing of its corners (or, at any slope, exceeds
    /// [`DEFAULT_BRIDGE_FACTOR`] times it, with `gaps`); `∞` turns both rules off.
    pub factor: f64,
    /// Whether the gap rule runs too (trimming: yes; the strips: not yet, it drops
    /// lookahead's long fans on clean grids with the area and dihedral weights).
    pub gaps: bool,
}

/// Refuses a depth-jump factor that is NaN or not positive (`∞` turns the rules off); the
/// error names the parameter and its value. O(1).
pub(crate) fn check_jump_factor(factor: f64) -> Result<()> {
    if factor.is_nan() || factor <= 0.0 {
        return Err(Error::InvalidParameter {
            name: "jump_factor",
            value: factor.to_string(),
            expected: "a positive multiple of the local spacing (or inf)",
        });
    }
    Ok(())
}

/// Refuses 3-D `points` whose count is not `n_points`, the planar points they lie over
/// index for index (the depth-jump rules read both). O(1).
pub(crate) fn check_points_match(points: &[DVec3], n_points: usize) -> Result<()> {
    if points.len() != n_points {
        return Err(Error::InvalidParameter {
            name: "points",
            value: format!("{} points for {n_points} planar points", points.len()),
            expected: "one 3-D point per planar point",
        });
    }
    Ok(())
}

/// The two local 3-D spacings of a vertex, from the lengths of its distinct edges.
#[derive(Debug, Clone, Copy)]
pub(super) struct Spacing {
    /// The upper median. It adapts to the scan: on lines 4 times farther apart than their
    /// points it is about the line distance, on a steep slope the length down the slope,
    /// while a vertex on the rim of a wall or a bore has most of its edges on its own side
    /// and keeps a short one.
    pub(super) median: f64,
    /// The spacing across scan lines: the lower median of the edges but the two shortest
    /// (usually those to the vertex's neighbours on its own line), or the longest edge of
    /// a vertex with at most two. On lines 10 times farther apart than their points it is
    /// the line distance even on the first and last line, where a vertex may have a single
    /// edge across (the median is then the step along the line).
    pub(super) across: f64,
}

/// [`Spacing`] of each vertex of `unit` (points in the unit box, see [`Normalizer`]) for
/// which `wanted` holds (`∞` for the others and vertices of no triangle), in input units
/// (`scale`: the box's half extent, 1 for a box of size 0). O(m + k log k) for the k edges
/// at wanted vertices, in parallel.
pub(super) fn spacings(
    unit: &[DVec3],
    scale: f64,
    triangles: &[[u32; 3]],
    wanted: impl Fn(u32) -> bool + Sync,
) -> Result<Vec<Spacing>> {
    let edge = |t: &[u32; 3], k: usize| (t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3]));
    let wanted_edge = |&(a, b): &(u32, u32)| wanted(a) || wanted(b);
    let count = triangles
        .par_iter()
        .with_min_len(BLOCK)
        .map(|t| (0..3).filter(|&k| wanted_edge(&edge(t, k))).count())
        .sum();
    let mut edges = try_vec(SPACINGS, count)?;
    edges.extend(
        triangles
            .iter()
            .flat_map(|t| (0..3).map(move |k| edge(t, k)))
            .filter(wanted_edge),
    );
    edges.par_sort_unstable();
    edges.dedup();
    let n = unit.len();
    let mut start = try_filled(SPACINGS, 0u32, n + 1)?;
    for &(a, b) in &edges {
        start[a as usize + 1] += 1;
        start[b as usize + 1] += 1;
    }
    for v in 0..n {
        start[v + 1] += start[v];
    }
    let mut fill = crate::budget::try_collect(SPACINGS, start.iter().copied())?;
    let mut lengths = try_filled(SPACINGS, 0.0, start[n] as usize)?;
    for &(a, b) in &edges {
        // Lengths in the unit box: no overflow at 1e300 or underflow at 1e-300.
        let d = (unit[a as usize] - unit[b as usize]).length();
        for v in [a, b] {
            lengths[fill[v as usize] as usize] = d;
            fill[v as usize] += 1;
        }
    }
    drop((edges, fill));
    let none = Spacing {
        median: f64::INFINITY,
        across: f64::INFINITY,
    };
    let mut out = try_filled(SPACINGS, none, n)?;
    let mut rest = lengths.as_mut_slice();
    // Each vertex's lengths are its own slice: split them off in order, then sort and
    // select in parallel.
    let mut own: Vec<(usize, &mut [f64])> = Vec::new();
    for v in 0..n {
        let (here, after) = rest.split_at_mut((start[v + 1] - start[v]) as usize);
        rest = after;
        if !here.is_empty() && wanted(v as u32) {
            own.push((v, here));
        }
    }
    let found: Vec<(usize, Spacing)> = own
        .into_par_iter()
        .with_min_len(1 << 10)
        .map(|(v, own)| {
            // A vertex has a handful of edges: sorting them is cheaper than two selects.
            own.sort_unstable_by(f64::total_cmp);
            let across = if own.len() <= 2 {
                own[own.len() - 1]
            } else {
                own[2 + (own.len() - 3) / 2]
            };
            let spacing = Spacing {
                median: own[own.len() / 2] * scale,
                across: across * scale,
            };
            (v, spacing)
        })
        .collect();
    for (v, spacing) in found {
        out[v] = spacing;
    }
    Ok(out)
}

/// What the spacings' buffers are called in memory errors.
const SPACINGS: &str = "the local spacings";

/// `n` atomic minima of lengths, all `∞` to start with. Lengths are ≥ +0, whose bit
/// patterns order as the numbers do, so [`lower`] on the bits takes the minimum, in any
/// order. Errors: an [`Error::OutOfMemory`] naming `what`. O(n), in parallel.
pub(crate) fn infinities(what: &str, n: usize) -> Result<Vec<AtomicU64>> {
    let all = (0..n)
        .into_par_iter()
        .with_min_len(BLOCK)
        .map(|_| AtomicU64::new(f64::INFINITY.to_bits()));
    try_par_collect(what, all)
}

/// Lowers the length held in `at` to `length` (≥ +0) if that is smaller. A plain load
/// first: most lengths are not the minimum, and a read-modify-write on each is a locked
/// instruction. O(1).
#[inline]
pub(crate) fn lower(at: &AtomicU64, length: f64) {
    if length.to_bits() < at.load(Ordering::Relaxed) {
        at.fetch_min(length.to_bits(), Ordering::Relaxed);
    }
}

/// Whether an edge of 3-D length `length3`, `flat` long in the plane (same units), bridges
/// a depth jump where the local 3-D spacing is `spacing`: steeper than 45° over the plane
/// (the height step exceeds the planar length) and longer than `factor` × `spacing`. Long
/// flat edges are the planar rule's business (an outline, a hole seen in the plane). The
/// one depth-jump rule, for triangles ([`bridging_triangles`]) and along scan lines
/// ([`crate::strips::lines::split_at_jumps`]). O(1).
pub fn is_depth_jump(length3: f64, flat: f64, spacing: f64, factor: f64) -> bool {
    is_steep(length3, flat) && length3 > factor * spacing
}

/// Whether an edge of 3-D length `length3`, `flat` long in the plane, is steeper than 45°.
pub(super) fn is_steep(length3: f64, flat: f64) -> bool {
    length3 * length3 > 2.0 * flat * flat
}

/// For each of `triangles`, whether it bridges a depth jump or a gap: its longest 3-D edge
/// is a jump by [`is_depth_jump`] against the smallest [`Spacing::median`] of its corners,
/// or at any slope longer than [`DEFAULT_BRIDGE_FACTOR`] times the smallest spacing
/// across lines ([`Spacing::across`]) of its corners (both computed over `triangles`; the
/// bridge rule again over what is kept, while it drops something). `uv` must be the orthogonal
/// projection of `jumps.points`, in the same
/// units; all `false` when `jumps.factor` is infinite. O(m log m). Errors: memory the
/// system refuses for the gap rule's fans ([`Error::OutOfMemory`]).
pub fn bridging_triangles(
    uv: &[[f64; 2]],
    triangles: &[[u32; 3]],
    jumps: DepthJumps,
) -> Result<Vec<bool>> {
    match UnitJumps::when_finite(Some(jumps))? {
        Some(unit) => bridging_in_box(uv, triangles, &unit),
        None => try_filled("the bridging flags", false, triangles.len()),
    }
}

/// The rules of [`DepthJumps`] on the points mapped into the unit box once (3-D work there:
/// lengths of 1e300- or 1e-300-sized parts stay finite), not once per corner.
pub(super) struct UnitJumps {
    /// `Normalizer::fit(points).apply(p)` of every point.
    pub(super) unit: Vec<DVec3>,
    /// The box's half extent (input units per unit), 1 for a box of size 0.
    pub(super) scale: f64,
    /// As [`DepthJumps::factor`].
    pub(super) factor: f64,
    /// As [`DepthJumps::gaps`].
    pub(super) gaps: bool,
}

impl UnitJumps {
    /// `jumps` with its points mapped into their unit box, None without jumps or with an
    /// infinite factor (the rules are off). Errors: an [`Error::OutOfMemory`] for the
    /// mapped points. O(n), in parallel.
    pub(super) fn when_finite(jumps: Option<DepthJumps>) -> Result<Option<Self>> {
        jumps
            .filter(|j| j.factor.is_finite())
            .map(|j| Self::gathered(j, None))
            .transpose()
    }

    /// The rules of `jumps` in the unit box (as [`UnitJumps::when_finite`]) on the points
    /// `jumps.points[i]` for `i` in `order` (all points when None), in that order: the box
    /// is that of all points either way. Errors: an [`Error::OutOfMemory`] for the mapped
    /// points. O(n), in parallel.
    pub(super) fn gathered(jumps: DepthJumps, order: Option<&[u32]>) -> Result<Self> {
        const WHAT: &str = "the points in their unit box";
        let norm = Normalizer::fit(jumps.points);
        let unit = match order {
            Some(order) => {
                let unit = order.par_iter().with_min_len(BLOCK);
                try_par_collect(WHAT, unit.map(|&i| norm.apply(jumps.points[i as usize])))?
            }
            None => {
                let unit = jumps.points.par_iter().with_min_len(BLOCK);
                try_par_collect(WHAT, unit.map(|&p| norm.apply(p)))?
            }
        };
        Ok(UnitJumps {
            unit,
            scale: if norm.half_extent > 0.0 {
                norm.half_extent
            } else {
                1.0
            },
            factor: jumps.factor,
            gaps: jumps.gaps,
        })
    }

    /// The three 3-D edge lengths of `t` in the unit box, edge k from corner k. O(1).
    pub(super) fn lengths(&self, t: &[u32; 3]) -> [f64; 3] {
        [0, 1, 2].map(|k| (self.unit[t[k] as usize] - self.unit[t[(k + 1) % 3] as usize]).length())
    }
}

/// [`bridging_triangles`] on points already in their unit box. The rounds after the first
/// are judged on the neighbourhood of what the last round dropped ([`next_round`]), not on
/// every triangle again. O(m log m).
pub(super) fn bridging_in_box(
    uv: &[[f64; 2]],
    triangles: &[[u32; 3]],
    jumps: &UnitJumps,
) -> Result<Vec<bool>> {
    let (shape, shortest_at) = shapes(uv, triangles, jumps)?;
    let mut dropped = round(&jumps.unit, triangles, &shape, jumps, true, |v| {
        f64::from_bits(shortest_at[v as usize].load(Ordering::Relaxed))
    })?;
    drop(shortest_at);
    // A fan over a gap inflates the spacing at its apex until its longest rungs are gone:
    // the bridge rule runs again on what is kept while it drops something. The jump rule
    // runs once (again, it would eat into the walls' rims).
    if jumps.gaps && dropped.iter().any(|&d| d) {
        let around = Fans::new(jumps.unit.len(), triangles)?;
        let mut last = try_indices("the triangles dropped", 0..triangles.len() as u32, |i| {
            dropped[i as usize]
        })?;
        while !last.is_empty() {
            last = next_round(triangles, &shape, jumps, &around, &dropped, &last)?;
            for &i in &last {
                dropped[i as usize] = true;
            }
        }
    }
    Ok(dropped)
}

/// Each triangle's longest 3-D edge, negative when steep, and the shortest 3-D edge of any
/// triangle at each vertex (see [`infinities`]). Errors: an [`Error::OutOfMemory`] for
/// the shapes. O(m), in parallel.
pub(super) fn shapes(
    uv: &[[f64; 2]],
    triangles: &[[u32; 3]],
    jumps: &UnitJumps,
) -> Result<(Vec<f64>, Vec<AtomicU64>)> {
    let to_unit = 1.0 / jumps.scale;
    let shortest_at = infinities(SPACINGS, jumps.unit.len())?;
    let shape = triangles.par_iter().with_min_len(BLOCK).map(|t| {
        let lengths = jumps.lengths(t);
        let k = (0..3).fold(0, |a, b| if lengths[b] > lengths[a] { b } else { a });
        let (a, b) = (t[k] as usize, t[(k + 1) % 3] as usize);
        let flat = planar_distance(uv[a], uv[b]) * to_unit;
        let shortest = lengths.iter().copied().fold(f64::INFINITY, f64::min);
        for &v in t {
            lower(&shortest_at[v as usize], shortest);
        }
        if is_steep(lengths[k], flat) {
            -lengths[k]
        } else {
            lengths[k]
        }
    });
    let shape = try_par_collect("the triangles' shapes", shape)?;
    Ok((shape, shortest_at))
}

/// One round of the rules over `list` (corners indexing `unit`) with its `shape` (longest
/// 3-D edge, negative when steep): which triangles they drop, the depth-jump rule only
/// `with_jumps`; `shortest_at(v)` is the shortest 3-D edge of the listed triangles at
/// corner v. Errors: an [`Error::OutOfMemory`]. O(m + k log k) for the k edges at
/// corners of triangles the shortest edges do not clear.
pub(super) fn round(
    unit: &[DVec3],
    list: &[[u32; 3]],
    shape: &[f64],
    jumps: &UnitJumps,
    with_jumps: bool,
    shortest_at: impl Fn(u32) -> f64 + Sync,
) -> Result<Vec<bool>> {
    const WHAT: &str = "a round of the jump and gap rules";
    let to_unit = 1.0 / jumps.scale;
    // The shortest 3-D edge at each vertex bounds its spacings from below, so a
    // triangle no longer than the bridge factor times that bound at every corner is no
    // bridge, and a flat one no jump: the spacings (a sort of edges) are needed only
    // at the corners of the others (few, or none on a smooth, evenly sampled scan).
    let corner = (0..unit.len())
        .into_par_iter()
        .with_min_len(BLOCK)
        .map(|_| AtomicBool::new(false));
    let corner = try_par_collect(WHAT, corner)?;
    let any = list
        .par_iter()
        .zip(shape)
        .with_min_len(BLOCK)
        .map(|(t, &s)| {
            let (longest3, steep) = (s.abs(), s.is_sign_negative());
            let bound = t
                .iter()
                .map(|&v| shortest_at(v))
                .fold(f64::INFINITY, f64::min);
            let flagged = (with_jumps && steep && longest3 > jumps.factor * bound)
                || (jumps.gaps && longest3 > DEFAULT_BRIDGE_FACTOR * bound);
            if flagged {
                t.iter()
                    .for_each(|&v| corner[v as usize].store(true, Ordering::Relaxed));
            }
            flagged
        })
        .reduce(|| false, |a, b| a || b);
    if !any {
        return try_filled(WHAT, false, list.len());
    }
    let local = spacings(unit, jumps.scale, list, |v| {
        corner[v as usize].load(Ordering::Relaxed)
    })?;
    let verdicts = list
        .par_iter()
        .zip(shape)
        .with_min_len(BLOCK)
        .map(|(t, &s)| {
            let (longest3, steep) = (s.abs(), s.is_sign_negative());
            let nearest = |of: fn(&Spacing) -> f64| {
                t.iter()
                    .map(|&v| of(&local[v as usize]))
                    .fold(f64::INFINITY, f64::min)
                    * to_unit
            };
            (with_jumps && steep && longest3 > jumps.factor * nearest(|s| s.median))
                || (jumps.gaps && longest3 > DEFAULT_BRIDGE_FACTOR * nearest(|s| s.across))
        });
    try_par_collect(WHAT, verdicts)
}

/// A round of the bridge rule after the first, over the triangles not `dropped`, given the
/// triangles the round before dropped (`last`): the ones it drops now.
///
/// Only triangles near `last` can change their verdict. A triangle's verdict depends on the
/// spacings of its corners, each over the kept triangles at that corner, and on which
/// corners have them at all (those of triangles whose shortest edges do not clear them,
/// each shortest edge over the kept triangles at a corner). With R0 the corners of `last`
/// and R(k+1) R(k) and the corners of kept triangles at R(k): a kept triangle with no
/// corner in R1 sees the same spacings as in the round before (no corner's triangles
/// changed) at no more corners (a triangle at its corner is cleared as before, or sees
/// fewer triangles only at R0, so the corner would be in R1), and was kept then, so it is
/// kept now; the verdicts of those with a corner in R1 depend on the kept triangles at R3,
/// which are judged as the whole round would judge them: the same verdicts, bit for bit,
/// on a few triangles. O(k log k) for k triangles around `last`.
pub(super) fn next_round(
    triangles: &[[u32; 3]],
    shape: &[f64],
    jumps: &UnitJumps,
    around: &Fans,
    dropped: &[bool],
    last: &[u32],
) -> Result<Vec<u32>> {
    let kept_at = |v: u32| {
        around
            .of(v as usize)
            .iter()
            .copied()
            .filter(|&i| !dropped[i as usize])
    };
    let mut rings: Vec<Vec<u32>> = vec![last.iter().flat_map(|&i| triangles[i as usize]).collect()];
    for _ in 0..3 {
        let inner = rings.last().expect("R0");
        let mut outer: Vec<u32> = inner
            .iter()
            .flat_map(|&v| kept_at(v).flat_map(|i| triangles[i as usize]))
            .chain(inner.iter().copied())
            .collect();
        outer.sort_unstable();
        outer.dedup();
        rings.push(outer);
    }
    let mut near: Vec<u32> = rings[3].iter().flat_map(|&v| kept_at(v)).collect();
    near.sort_unstable();
    near.dedup();
    // The neighbourhood as a problem of its own: its corners renumbered in order.
    let mut corners: Vec<u32> = near.iter().flat_map(|&i| triangles[i as usize]).collect();
    corners.sort_unstable();
    corners.dedup();
    let local = |v: u32| corners.binary_search(&v).expect("a corner") as u32;
    let list: Vec<[u32; 3]> = near
        .iter()
        .map(|&i| triangles[i as usize].map(local))
        .collect();
    let unit: Vec<DVec3> = corners.iter().map(|&v| jumps.unit[v as usize]).collect();
    let mut shortest_at = vec![f64::INFINITY; corners.len()];
    for (&i, t) in near.iter().zip(&list) {
        let shortest = jumps
            .lengths(&triangles[i as usize])
            .into_iter()
            .fold(f64::INFINITY, f64::min);
        for &v in t {
            shortest_at[v as usize] = shortest_at[v as usize].min(shortest);
        }
    }
    let near_shape: Vec<f64> = near.iter().map(|&i| shape[i as usize]).collect();
    let verdicts = round(&unit, &list, &near_shape, jumps, false, |v| {
        shortest_at[v as usize]
    })?;
    let in_r1 = |v: &u32| rings[1].binary_search(v).is_ok();
    Ok(near
        .iter()
        .zip(verdicts)
        .filter(|&(&i, drop)| drop && triangles[i as usize].iter().any(in_r1))
        .map(|(&i, _)| i)
        .collect())
}
