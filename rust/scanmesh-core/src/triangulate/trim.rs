//! Trimming a convex-hull triangulation back to the scanned outline: long edges span gaps,
//! and triangles far longer in 3-D than the spacing around them bridge depth jumps.

use crate::budget::{try_filled, try_indices, try_par_collect, try_vec};
use crate::geometry::orient2d;
use crate::geometry::planar_distance;
use crate::geometry::UnitSquare;
use crate::mesh::NONE;
use crate::mesh::{prev, HalfEdgeMesh, COLLINEAR_SINE};
use crate::progress::Progress;
use crate::triangulate::delaunay::{relabel, DELAUNAY_PASSES};
use crate::triangulate::holes::{covering_holes, DEFAULT_HOLE_FACTOR};
use crate::triangulate::jumps::{
    bridging_in_box, check_jump_factor, check_points_match, infinities, lower, DepthJumps,
    UnitJumps,
};
use crate::{Error, Result};
use glam::DVec3;
use rayon::prelude::*;

/// Triangles per rayon task in the passes over all of them.
const BLOCK: usize = 1 << 14;

/// Default `max_edge` as a multiple of the median nearest-neighbour spacing. Five spacings
/// keep scans whose lines are up to about 4.5 times farther apart than their points, and
/// still open a bore or a missed region a few lines wide.
pub const DEFAULT_MAX_EDGE_FACTOR: f64 = 5.0;

/// Distances below this fraction of the planar extent are not spacings but near-duplicates
/// (a point scanned twice, a surface folded onto itself in the plane); `median_spacing`
/// skips them, or a scan with many of them would be trimmed away entirely.
pub const NEAR_DUPLICATE_RELATIVE: f64 = 1e-9;

/// Median over used vertices of the planar distance to the nearest neighbour, taken along
/// triangulation edges (the nearest-neighbour graph is a subgraph of Delaunay's), ignoring
/// near-duplicates (see `NEAR_DUPLICATE_RELATIVE`). 0 when there are no triangles.
/// Errors: an [`Error::OutOfMemory`] for its per-point
/// buffer. O(m + n log n).
pub fn median_spacing(uv: &[[f64; 2]], triangles: &[[u32; 3]]) -> Result<f64> {
    // Minima and maxima do not depend on the order they are taken in: the parallel passes
    // give the serial result bit for bit.
    let bounds = |(lo, hi): ([f64; 2], [f64; 2]), t: &[u32; 3]| {
        t.iter().fold((lo, hi), |(lo, hi), &v| {
            let p = uv[v as usize];
            (
                [lo[0].min(p[0]), lo[1].min(p[1])],
                [hi[0].max(p[0]), hi[1].max(p[1])],
            )
        })
    };
    let empty = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    let (lo, hi) = triangles
        .par_iter()
        .with_min_len(BLOCK)
        .fold(|| empty, bounds)
        .reduce(
            || empty,
            |(a, b), (c, d)| {
                (
                    [a[0].min(c[0]), a[1].min(c[1])],
                    [b[0].max(d[0]), b[1].max(d[1])],
                )
            },
        );
    nearest_median(uv, triangles, None, (lo, hi))
}

/// [`median_spacing`] of a triangulation of every point of `uv` (each point a vertex or
/// an exact copy of one, as [`delaunay_ordered`](crate::triangulate::delaunay::delaunay_ordered) returns
/// them) with its half-edge `twins`: the bounding box of the points themselves (the
/// vertices' box: a copy adds no coordinate), read in order rather than through the
/// triangles' corners, and each edge measured once, from its lower half-edge, not from both
/// of its triangles. Minima do not depend on the order or the number of times they are
/// taken: the same value bit for bit, with half the square roots. O(n + m), in parallel.
fn triangulation_spacing(uv: &[[f64; 2]], triangles: &[[u32; 3]], twins: &[u32]) -> Result<f64> {
    let empty = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    let widen = |(lo, hi): ([f64; 2], [f64; 2]), p: [f64; 2]| {
        (
            [lo[0].min(p[0]), lo[1].min(p[1])],
            [hi[0].max(p[0]), hi[1].max(p[1])],
        )
    };
    let bounds = uv
        .par_iter()
        .with_min_len(BLOCK)
        .fold(|| empty, |b, &p| widen(b, p))
        .reduce(|| empty, |b, (lo, hi)| widen(widen(b, lo), hi));
    nearest_median(uv, triangles, Some(twins), bounds)
}

/// The median of the nearest-neighbour distances along the edges of `triangles` (each
/// edge once when `twins` are given, else from every triangle holding it), near-duplicates
/// judged against the box `(lo, hi)` of the vertices. O(m + n), in parallel.
fn nearest_median(
    uv: &[[f64; 2]],
    triangles: &[[u32; 3]],
    twins: Option<&[u32]>,
    (lo, hi): ([f64; 2], [f64; 2]),
) -> Result<f64> {
    let extent = (hi[0] * 0.5 - lo[0] * 0.5).max(hi[1] * 0.5 - lo[1] * 0.5);
    let negligible = NEAR_DUPLICATE_RELATIVE * extent;
    let nearest = infinities(SPACING, uv.len())?;
    triangles
        .par_iter()
        .enumerate()
        .with_min_len(BLOCK)
        .for_each(|(i, t)| {
            for k in 0..3 {
                // The twin's triangle measures this edge when its half-edge is the lower.
                if let Some(twins) = twins {
                    let g = twins[3 * i + k];
                    if g != NONE && (g as usize) < 3 * i + k {
                        continue;
                    }
                }
                let (a, b) = (t[k], t[(k + 1) % 3]);
                let d = planar_distance(uv[a as usize], uv[b as usize]);
                if d <= negligible {
                    continue;
                }
                for v in [a, b] {
                    lower(&nearest[v as usize], d);
                }
            }
        });
    let lengths = nearest
        .into_par_iter()
        .with_min_len(BLOCK)
        .map(|d| f64::from_bits(d.into_inner()));
    let mut finite = try_par_collect(SPACING, lengths)?;
    finite.retain(|d| d.is_finite());
    if finite.is_empty() {
        return Ok(0.0);
    }
    let mid = finite.len() / 2;
    Ok(*finite.select_nth_unstable_by(mid, f64::total_cmp).1)
}

/// Drops triangles whose longest planar edge exceeds `max_edge`, and with `jumps` those
/// that bridge a depth jump or a gap; then peels numerically degenerate triangles off the
/// boundary and resolves pinches.
///
/// A depth jump (a wall, a step, the rim of a bore, an occluded gap) leaves the points on
/// either side close in the plane but far apart in 3-D: a triangle is dropped when its
/// longest 3-D edge is steeper than 45° over the plane (`uv` must be the orthogonal
/// projection of `jumps.points`, in the same units) and exceeds `jumps.factor` times the
/// smallest local spacing of its corners (computed over the input triangles), or, at any
/// slope, [`DEFAULT_BRIDGE_FACTOR`](crate::triangulate::jumps::DEFAULT_BRIDGE_FACTOR) times their
/// spacing across lines
/// (`bridging_triangles`), or that is far longer
/// and larger in the plane than the
/// triangles around it (`covering_holes` at [`DEFAULT_HOLE_FACTOR`]), so the hole stays
/// open. Straight stretches
/// of a scanned outline put collinear points on the convex hull, and
/// Delaunay closes them with zero-area slivers whose angles (0, 0, π) make a boundary
/// vertex look interior; they cover no area, so dropping them changes no surface. A pinch is a
/// vertex where two fans touch only at a point; there the triangles of all
/// fans but the largest are dropped (repeatedly, as a drop can pinch a neighbour), so the
/// result is a valid [`HalfEdgeMesh`]. `max_edge = ∞` and no `jumps` keep everything but
/// the slivers. Input triangles must form a valid planar triangulation. O(m) after
/// building their half-edge twins (see [`delaunay_trimmed`], which has them from the
/// triangulation). Errors: a `max_edge` or `jumps.factor` that is NaN or not positive, with a
/// finite factor `jumps.points` not one per planar point, triangles that are not an oriented
/// manifold.
pub fn trim_long_edges(
    uv: &[[f64; 2]],
    triangles: &[[u32; 3]],
    max_edge: f64,
    jumps: Option<DepthJumps>,
) -> Result<Vec<[u32; 3]>> {
    check_max_edge(max_edge)?;
    if let Some(j) = &jumps {
        check_jump_factor(j.factor)?;
        if j.factor.is_finite() {
            check_points_match(j.points, uv.len())?;
        }
    }
    let twins = twins_of(uv.len(), triangles)?;
    let jumps = UnitJumps::when_finite(jumps)?;
    trim(
        uv,
        triangles,
        &twins,
        max_edge,
        jumps,
        None,
        (&Progress::new(), 0),
    )
}

/// Refuses a planar trimming length that is NaN or not positive (`∞` keeps every length);
/// the error names the parameter and its value (input units). O(1).
pub(crate) fn check_max_edge(max_edge: f64) -> Result<()> {
    if max_edge.is_nan() || max_edge <= 0.0 {
        return Err(Error::InvalidParameter {
            name: "max_edge",
            value: max_edge.to_string(),
            expected: "a positive length (or inf)",
        });
    }
    Ok(())
}

/// The parameter checks of trimming in one call: a `max_edge` (input units) and a
/// `jump_factor` (multiples of the local spacing) that are NaN or not positive are refused
/// (`∞` turns either rule off), `max_edge` first; the error names the parameter and its
/// value. What [`trim_long_edges`] and [`delaunay_trimmed`] check before any work, for a
/// caller that wants to check before converting its input. O(1).
pub fn check_trim_lengths(max_edge: f64, jump_factor: f64) -> Result<()> {
    check_max_edge(max_edge)?;
    check_jump_factor(jump_factor)
}

/// A Delaunay triangulation trimmed in one call ([`delaunay_trimmed`]).
#[derive(Debug, Clone)]
pub struct Trimmed {
    /// The kept counter-clockwise triangles, in input indices.
    pub triangles: Vec<[u32; 3]>,
    /// As [`Delaunay::duplicate_of`](crate::triangulate::Delaunay::duplicate_of).
    pub duplicate_of: Vec<u32>,
    /// Points (ascending) that were a vertex of the triangulation and of no kept triangle.
    pub trimmed: Vec<u32>,
    /// The planar trimming length used (input units).
    pub max_edge: f64,
    /// Seconds spent triangulating and trimming.
    pub seconds: [f64; 2],
}

/// [`delaunay`](fn@crate::triangulate::delaunay) of `uv` then the rules of [`trim_long_edges`]: at
/// `max_edge`, or for None
/// [`DEFAULT_MAX_EDGE_FACTOR`] × [`median_spacing`]; when that length is finite, depth jumps
/// on the 3-D `points` at `jump_factor` (∞: off). One call, so the triangulation's twins
/// serve the trimming and no face array crosses to the caller in between. Errors: those of
/// [`check_trim_lengths`], with a finite `jump_factor` `points` not one per planar point,
/// and those of the triangulation. `progress` gets `TRIMMED_PASSES` × n points planned
/// at the start and counted a pass at a time. O(n log n).
pub fn delaunay_trimmed(
    uv: &[[f64; 2]],
    points: &[DVec3],
    max_edge: Option<f64>,
    jump_factor: f64,
    progress: &Progress,
) -> Result<Trimmed> {
    check_trim_lengths(max_edge.unwrap_or(1.0), jump_factor)?;
    if jump_factor.is_finite() {
        check_points_match(points, uv.len())?;
    }
    let n = uv.len() as u64;
    // the triangulation plans its own passes as it starts: the trimming's come first
    progress.plan((TRIMMED_PASSES - DELAUNAY_PASSES) * n);
    let clock = std::time::Instant::now();
    let (d, order) = crate::triangulate::delaunay::delaunay_ordered(uv, progress)?;
    let triangulated = clock.elapsed().as_secs_f64();
    // The trimming runs in the triangulation's own labels, on the points gathered into
    // them: its passes then read memory in order (see `delaunay_ordered`).
    let gathered: Option<Vec<[f64; 2]>> = order.as_ref().map(|to_input| {
        to_input
            .par_iter()
            .with_min_len(BLOCK)
            .map(|&i| uv[i as usize])
            .collect()
    });
    let local_uv = gathered.as_deref().unwrap_or(uv);
    let limit = match max_edge {
        Some(limit) => limit,
        None => DEFAULT_MAX_EDGE_FACTOR * triangulation_spacing(local_uv, &d.triangles, &d.twins)?,
    };
    progress.add(n);
    let jumps = (limit.is_finite() && jump_factor.is_finite()).then(|| {
        let jumps = DepthJumps {
            points,
            factor: jump_factor,
            gaps: true,
        };
        UnitJumps::gathered(jumps, order.as_deref())
    });
    let jumps = jumps.transpose()?;
    let mut triangles = trim(
        local_uv,
        &d.triangles,
        &d.twins,
        limit,
        jumps,
        order.as_deref(),
        (progress, n),
    )?;
    drop(gathered);
    let mut vertex = try_filled(TRIMMED, false, uv.len())?;
    d.triangles
        .as_flattened()
        .iter()
        .for_each(|&v| vertex[v as usize] = true);
    triangles
        .as_flattened()
        .iter()
        .for_each(|&v| vertex[v as usize] = false);
    let mut trimmed = try_indices(TRIMMED, 0..uv.len() as u32, |v| vertex[v as usize])?;
    if let Some(to_input) = &order {
        relabel(&mut triangles, to_input);
        trimmed.iter_mut().for_each(|v| *v = to_input[*v as usize]);
        trimmed.sort_unstable();
    }
    progress.add(n);
    Ok(Trimmed {
        triangles,
        duplicate_of: d.duplicate_of,
        trimmed,
        max_edge: limit,
        seconds: [triangulated, clock.elapsed().as_secs_f64() - triangulated],
    })
}

/// The rules of [`trim_long_edges`] as keep flags over `triangles` (with their `twins`):
/// the length and jump tests in parallel, then the boundary rounds (slivers, pinches) on
/// the flags, each round a scan of the boundary of what is kept. `to_input` (when the
/// labels are not the caller's) maps them back for the pinch tie-break. `jumps` is taken
/// by value and dropped once the jump and gap rounds are done: its unit-box copy of the
/// 3-D points (24 bytes a point) is not held through the hole rule and the peeling, where
/// the call peaks. `(progress, n)`: counts the n points once the tests are done and once
/// the peeling is. O(m) per round.
fn trim(
    uv: &[[f64; 2]],
    triangles: &[[u32; 3]],
    twins: &[u32],
    max_edge: f64,
    jumps: Option<UnitJumps>,
    to_input: Option<&[u32]>,
    (progress, n): (&Progress, u64),
) -> Result<Vec<[u32; 3]>> {
    let short = ShortEnough::new(max_edge);
    let longest_within =
        |t: &[u32; 3]| (0..3).all(|k| short.test(uv[t[k] as usize], uv[t[(k + 1) % 3] as usize]));
    let mut bridges = jumps
        .as_ref()
        .map_or_else(|| Ok(Vec::new()), |j| bridging_in_box(uv, triangles, j))?;
    let holes_too = jumps.is_some_and(|j| j.gaps && j.factor.is_finite());
    if holes_too {
        let holes = covering_holes(uv, triangles, DEFAULT_HOLE_FACTOR)?;
        bridges.iter_mut().zip(holes).for_each(|(b, h)| *b |= h);
    }
    let keep = triangles
        .par_iter()
        .enumerate()
        .with_min_len(BLOCK)
        .map(|(k, t)| longest_within(t) && !bridges.get(k).copied().unwrap_or(false));
    let keep = try_par_collect(KEEP, keep)?;
    drop(bridges);
    progress.add(n);
    let kept = peel_flags(uv, triangles, twins, keep, to_input)?;
    progress.add(n);
    Ok(kept)
}

/// Passes over the points [`delaunay_trimmed`] counts in its `progress`: those of the
/// triangulation, the spacing, the trimming's tests, its peeling, the points left out.
pub(crate) const TRIMMED_PASSES: u64 = DELAUNAY_PASSES + 4;

/// What the keep flags and the triangles kept are called in memory errors.
const KEEP: &str = "the triangles trimming keeps";

/// What the nearest-neighbour lengths are called in memory errors.
const SPACING: &str = "the nearest-neighbour spacings";

/// What the points trimming leaves out are called in memory errors.
const TRIMMED: &str = "the points trimming leaves out";

/// `planar_distance(a, b) <= max_edge`, decided from the squared length where that is
/// far enough from the limit's square to leave no doubt (a relative margin of 1e-9
/// against rounding errors below 1e-15, square and product in range), else by
/// `planar_distance` itself: the same answers without a `hypot` for almost every edge.
struct ShortEnough {
    max_edge: f64,
    /// The squares below and above which the answer is certain, or None.
    certain: Option<(f64, f64)>,
}

impl ShortEnough {
    fn new(max_edge: f64) -> Self {
        let square = max_edge * max_edge;
        let certain = (square.is_finite() && square > 1e-280)
            .then_some((square * (1.0 - 1e-9), square * (1.0 + 1e-9)));
        ShortEnough { max_edge, certain }
    }

    #[inline]
    fn test(&self, a: [f64; 2], b: [f64; 2]) -> bool {
        if let Some((below, above)) = self.certain {
            let (dx, dy) = (a[0] - b[0], a[1] - b[1]);
            let square = dx * dx + dy * dy;
            if square < below {
                return true;
            }
            if square > above && square.is_finite() {
                return false;
            }
        }
        planar_distance(a, b) <= self.max_edge
    }
}

/// The triangles of `triangles` (with their half-edge `twins`) flagged in `keep`, without
/// the numerically degenerate triangles on the boundary of what is kept and with every
/// pinch resolved, repeated until neither is left; `to_input` as in [`trim`]. Errors: an
/// [`Error::OutOfMemory`] for the triangles kept. O(m) per round.
pub(crate) fn peel_flags(
    uv: &[[f64; 2]],
    triangles: &[[u32; 3]],
    twins: &[u32],
    keep: Vec<bool>,
    to_input: Option<&[u32]>,
) -> Result<Vec<[u32; 3]>> {
    let (keep, _) = peeled_flags(uv, triangles, twins, keep, to_input)?;
    let mut kept = try_vec(KEEP, keep.par_iter().filter(|&&k| k).count())?;
    kept.extend(
        triangles
            .iter()
            .zip(&keep)
            .filter(|(_, &k)| k)
            .map(|(t, _)| *t),
    );
    Ok(kept)
}

/// [`peel_flags`] as flags: `keep` with the peeled triangles cleared, and the boundary of
/// what is left (its half-edges without a kept twin, ascending). O(m) per round.
pub(crate) fn peeled_flags(
    uv: &[[f64; 2]],
    triangles: &[[u32; 3]],
    twins: &[u32],
    mut keep: Vec<bool>,
    to_input: Option<&[u32]>,
) -> Result<(Vec<bool>, Vec<u32>)> {
    // Degeneracy is judged scale-free (areas of 1e-300-sized triangles underflow), on the
    // boundary's corners alone mapped into the unit square.
    let unit = UnitSquare::of(uv);
    loop {
        let kept = Kept {
            triangles,
            twins,
            keep: &keep,
            to_input,
        };
        let boundary = try_indices(KEEP, 0..twins.len() as u32, |h| {
            keep[(h / 3) as usize] && kept.twin(h) == NONE
        })?;
        let mut dropped = kept.pinched_fans_to_drop(&boundary, uv.len());
        dropped.extend(kept.degenerate_boundary_triangles(&boundary, uv, unit));
        if dropped.is_empty() {
            return Ok((keep, boundary));
        }
        for t in dropped {
            keep[t as usize] = false;
        }
    }
}

/// `kept` without the numerically degenerate triangles on its boundary and with every
/// pinch resolved (the triangles of all fans but the largest dropped), repeated until
/// neither is left: a valid [`HalfEdgeMesh`] when `kept` has no overlapping triangles in
/// the plane. Errors: `kept` is not an oriented manifold (an edge in three triangles, a
/// repeated directed edge: [`Error::InvalidFace`] or [`Error::Invariant`]), an
/// [`Error::OutOfMemory`]. O(m) per round.
pub fn peel(uv: &[[f64; 2]], kept: &[[u32; 3]]) -> Result<Vec<[u32; 3]>> {
    let twins = twins_of(uv.len(), kept)?;
    let keep = try_filled(KEEP, true, kept.len())?;
    peel_flags(uv, kept, &twins, keep, None)
}

/// [`peel`] where it can, `kept` itself where it is no oriented manifold (the caller's
/// planar check then names why, on the triangles as they are). Errors: an
/// [`Error::OutOfMemory`]. O(m) per round.
pub(crate) fn peel_or_keep(uv: &[[f64; 2]], kept: Vec<[u32; 3]>) -> Result<Vec<[u32; 3]>> {
    match peel(uv, &kept) {
        Err(e @ Error::OutOfMemory { .. }) => Err(e),
        Err(_) => Ok(kept),
        Ok(peeled) => Ok(peeled),
    }
}

/// True when planar triangle (a, b, c) is not counter-clockwise, or is a numerically
/// collinear sliver: its angles are about (0, 0, π), one corner lying on the segment between
/// the other two, so that it covers no area beyond rounding. Tested on the middle angle,
/// whose sine is twice the area over the product of the longest and shortest edges (they
/// meet at its corner), against [`COLLINEAR_SINE`].
///
/// A triangle with one tiny angle only (a needle: two corners a near-duplicate pair, the
/// third far away, angles about (0, φ, π − φ)) is not a sliver: it is a real part of the
/// surface, and peeling it off the hull would open a gap whose far corner then pinches
/// the mesh in two (five points lost a hull corner and 62 % of the area at `max_edge = ∞`).
/// [`well_formed`](crate::mesh::well_formed) bounds the smallest angle and refuses both,
/// as flips must; peeling may only drop the first. O(1).
fn collinear_sliver(a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> bool {
    let area2 = orient2d(a, b, c);
    if area2 <= 0.0 {
        return true;
    }
    let length = |p: [f64; 2], q: [f64; 2]| planar_distance(p, q);
    let sides = [length(a, b), length(b, c), length(c, a)];
    let longest = sides[0].max(sides[1]).max(sides[2]);
    let shortest = sides[0].min(sides[1]).min(sides[2]);
    area2 <= COLLINEAR_SINE * longest * shortest
}

/// The half-edge twins of `triangles` over `n_points` points (half-edge 3t + k runs from
/// corner k of triangle t; [`NONE`] on the boundary), as
/// [`Delaunay::twins`](crate::triangulate::Delaunay::twins) has them.
/// Errors: the triangles are not an oriented manifold. O(m).
fn twins_of(n_points: usize, triangles: &[[u32; 3]]) -> Result<Vec<u32>> {
    let mesh = HalfEdgeMesh::from_triangles(n_points, triangles)?;
    let twins = (0..mesh.n_half_edges() as u32).map(|h| mesh.twin(h));
    crate::budget::try_collect("the twins", twins)
}

/// The triangles still kept during trimming, seen as a mesh: a half-edge's twin counts only
/// when its triangle is kept.
struct Kept<'a> {
    triangles: &'a [[u32; 3]],
    twins: &'a [u32],
    keep: &'a [bool],
    /// Input labels of the vertices, when `triangles` are not in them.
    to_input: Option<&'a [u32]>,
}

impl Kept<'_> {
    fn twin(&self, h: u32) -> u32 {
        let g = self.twins[h as usize];
        if g != NONE && self.keep[(g / 3) as usize] {
            g
        } else {
            NONE
        }
    }

    fn start(&self, h: u32) -> u32 {
        self.triangles[(h / 3) as usize][(h % 3) as usize]
    }

    /// Kept triangles with a half-edge in `boundary` (no kept twin) that are collinear
    /// slivers ([`collinear_sliver`]) in `unit`'s coordinates, ascending. O(boundary).
    fn degenerate_boundary_triangles(
        &self,
        boundary: &[u32],
        uv: &[[f64; 2]],
        unit: UnitSquare,
    ) -> Vec<u32> {
        let mut slivers: Vec<u32> = boundary
            .iter()
            .map(|&h| h / 3)
            .filter(|&t| {
                let [a, b, c] = self.triangles[t as usize].map(|v| unit.map(uv[v as usize]));
                collinear_sliver(a, b, c)
            })
            .collect();
        slivers.dedup();
        slivers
    }

    /// Triangles of the smaller fans at every pinched vertex (more than one boundary
    /// half-edge leaves it); of equal fans, the one with the smallest triangle (corner
    /// indices sorted, compared lexicographically) stays. O(n + boundary + fans).
    fn pinched_fans_to_drop(&self, boundary: &[u32], n_vertices: usize) -> Vec<u32> {
        let mut leaving = vec![0u8; n_vertices];
        for &h in boundary {
            let c = &mut leaving[self.start(h) as usize];
            *c = c.saturating_add(1);
        }
        let mut pinched: Vec<(u32, u32)> = boundary
            .iter()
            .map(|&h| (self.start(h), h))
            .filter(|&(v, _)| leaving[v as usize] > 1)
            .collect();
        pinched.sort_unstable();
        let mut drop = Vec::new();
        for starts in pinched.chunk_by(|a, b| a.0 == b.0) {
            // Each boundary half-edge leaving the vertex begins one fan; walk it
            // counter-clockwise.
            let mut fans: Vec<Vec<u32>> = starts
                .iter()
                .map(|&(_, first)| {
                    let mut tris = vec![first / 3];
                    let mut h = first;
                    while self.twin(prev(h)) != NONE {
                        h = self.twin(prev(h));
                        tris.push(h / 3);
                    }
                    tris
                })
                .collect();
            // Ties go to the fan holding the smallest triangle by sorted corner indices, not
            // by triangle position: a piece of the scan with its points in the same order (a
            // tile of scanmesh.distributed) then resolves the pinch as the whole scan does.
            let key = |t: u32| {
                let mut c = self.triangles[t as usize];
                if let Some(to_input) = self.to_input {
                    c = c.map(|v| to_input[v as usize]);
                }
                c.sort_unstable();
                c
            };
            fans.sort_by_key(|f| (std::cmp::Reverse(f.len()), f.iter().map(|&t| key(t)).min()));
            drop.extend(fans.into_iter().skip(1).flatten());
        }
        drop.sort_unstable();
        drop.dedup();
        drop
    }
}

#[cfg(test)]
mod tests;
