//! Scan lines: detected from the order of the points, or given as a line id per point, and
//! split into segments at gaps.
//!
//! Everything here works on planar coordinates (the points projected onto the plane the
//! surface is a height field over): a scan line is straight or gently curved in that
//! plane, while in 3-D it climbs walls and folds over ridges, where its direction says
//! nothing about where the scanner went.
//!
//! Rules (h = the median planar distance between consecutive points, zero steps left out;
//! k = the gap factor, default [`DEFAULT_GAP_FACTOR`]):
//! - **direction** of the current line: the chord from its point up to
//!   [`DIRECTION_WINDOW`] points back to its last point; a line of one point (or of
//!   coincident points) has the scan's main axis, either way round: the dominant direction
//!   of all steps between 0.5 h and k h long;
//! - a step **continues** the line when it turns at most [`TURN_ANGLE_DEG`] from that
//!   direction, or when it is shorter than 0.5 h and the step after it does not turn
//!   (jitter and near-duplicates carry no direction);
//! - any other step **starts a new line**: a reversal of the scanning direction (zig-zag
//!   scans), a turn onto the next line (a zig-zag's short sideways move), or a jump longer
//!   than k h (a raster scan's return, a move to the next profile);
//! - a step that continues the line but is longer than k h is a **gap** (a hole, a bore,
//!   a missed region): the line goes on, in a new segment. Strips never bridge gaps.
//!
//! Explicit line ids (points with the same id form a line, in input order; lines in
//! ascending id) skip detection but are split at gaps the same way.

use crate::budget::{try_collect, try_filled, try_grow, try_indices, try_par_collect, try_vec};
use crate::geometry::{planar_distance, Normalizer};
use crate::{Error, Result};
use glam::DVec3;
use rayon::prelude::*;

/// Default gap factor k: a step longer than k × the median step is a gap (or a jump). Four
/// steps keep lines with a dropped point or two whole (a missing point doubles a step, two
/// triple it) and open every hole three points wide or more.
pub const DEFAULT_GAP_FACTOR: f64 = 4.0;

/// A step that turns more than this from the line's direction (degrees) ends the line.
/// Half a right angle: a zig-zag's reversal (180°) and its sideways move to the next line
/// (90°) are well beyond it, noise on a straight line well below.
pub const TURN_ANGLE_DEG: f64 = 45.0;

/// Points over which a line's current direction is measured (the chord's length in steps):
/// long enough to average jitter, short enough to follow a gently curving line.
pub const DIRECTION_WINDOW: usize = 32;

/// Points per rayon task in the passes over all points: large enough that splitting
/// costs nothing next to the work.
const BLOCK: usize = 1 << 14;

/// Scan lines split into segments, in the caller's point indices.
#[derive(Debug, Clone, PartialEq)]
pub struct ScanLines {
    /// Lines in scan order; each line its segments in scan order; each segment its point
    /// indices in scan order. Every segment has at least one point.
    pub lines: Vec<Vec<Vec<u32>>>,
    /// Median planar distance between consecutive points of a line (input units; 0 when no
    /// line has two distinct points).
    pub median_step: f64,
    /// The gap length: a longer step inside a line splits it (input units).
    pub gap: f64,
    /// (dropped point, the earlier point of its line it coincides with in the plane):
    /// repeated points would make zero-area triangles, so only the first is kept.
    pub duplicates: Vec<(u32, u32)>,
}

fn check_gap_factor(gap_factor: f64) -> Result<()> {
    if !(gap_factor.is_finite() && gap_factor > 0.0) {
        return Err(Error::InvalidParameter {
            name: "gap_factor",
            value: gap_factor.to_string(),
            expected: "a positive multiple of the median step",
        });
    }
    Ok(())
}

#[inline]
fn sub(p: [f64; 2], q: [f64; 2]) -> [f64; 2] {
    [p[0] - q[0], p[1] - q[1]]
}

#[inline]
fn norm(v: [f64; 2]) -> f64 {
    v[0].hypot(v[1])
}

/// Median of the non-zero values (0 for none). O(n).
fn median_nonzero(mut values: Vec<f64>) -> f64 {
    values.retain(|&x| x > 0.0);
    if values.is_empty() {
        return 0.0;
    }
    let mid = values.len() / 2;
    *values.select_nth_unstable_by(mid, f64::total_cmp).1
}

/// The dominant direction (unit, sign arbitrary) of the steps between `short` and `long`
/// in length: the major axis of their direction tensor. (1, 0) when there are none. O(n).
fn main_axis(uv: &[[f64; 2]], short: f64, long: f64) -> [f64; 2] {
    let (mut xx, mut xy, mut yy) = (0.0, 0.0, 0.0);
    for w in uv.windows(2) {
        let s = sub(w[1], w[0]);
        let len = norm(s);
        if len >= short && len <= long && len > 0.0 {
            let (x, y) = (s[0] / len, s[1] / len);
            xx += x * x;
            xy += x * y;
            yy += y * y;
        }
    }
    if xx + yy == 0.0 {
        return [1.0, 0.0];
    }
    // Angle of the major axis of [[xx, xy], [xy, yy]].
    let theta = 0.5 * (2.0 * xy).atan2(xx - yy);
    [theta.cos(), theta.sin()]
}

/// A line id per point (0..L−1 in scan order), detected from the point order by the rules
/// in the module documentation, with `gap_factor` as k. Errors: a non-finite coordinate, a
/// gap factor that is not positive, an [`Error::OutOfMemory`] for the ids. O(n).
pub fn detect_lines(uv: &[[f64; 2]], gap_factor: f64) -> Result<Vec<u32>> {
    crate::geometry::check_planar(uv)?;
    check_gap_factor(gap_factor)?;
    // The rules compare ratios of lengths; in the unit box their products stay finite.
    let (unit, _) = crate::geometry::normalize_plane(uv);
    let uv = &unit[..];
    let mut ids = try_vec("the line ids", uv.len())?;
    if uv.is_empty() {
        return Ok(ids);
    }
    let steps = uv.windows(2).map(|w| planar_distance(w[1], w[0]));
    let h = median_nonzero(try_collect("the steps", steps)?);
    let (short, long) = (0.5 * h, gap_factor * h);
    let axis = main_axis(uv, short, long);
    let cos_turn = TURN_ANGLE_DEG.to_radians().cos();
    let mut line = 0u32;
    let mut first = 0usize; // index of the current line's first point
    ids.push(0);
    for k in 1..uv.len() {
        let back = uv[(k - 1).saturating_sub(DIRECTION_WINDOW).max(first)];
        let chord = sub(uv[k - 1], back);
        let chord_len = norm(chord);
        // Whether step `s` keeps within the turn angle of the line's direction.
        let keeps_direction = |s: [f64; 2]| -> bool {
            let len = norm(s);
            let along = if chord_len > 0.0 {
                (s[0] * chord[0] + s[1] * chord[1]) / chord_len
            } else {
                // No direction yet: the main axis, either way round.
                (s[0] * axis[0] + s[1] * axis[1]).abs()
            };
            len == 0.0 || along >= cos_turn * len
        };
        let s = sub(uv[k], uv[k - 1]);
        // A short step that turns is jitter when the line goes on after it, and a zig-zag's
        // sideways move to the next line when the step after it turns too.
        let continues = keeps_direction(s)
            || (norm(s) < short && (k + 1 == uv.len() || keeps_direction(sub(uv[k + 1], uv[k]))));
        if !continues {
            line += 1;
            first = k;
        }
        ids.push(line);
    }
    Ok(ids)
}

/// Groups points by line id (same id = one line, in input order; lines by ascending id),
/// drops points that coincide in the plane with the previous point of their line, and
/// splits each line into segments at steps longer than `gap_factor` × the median step.
///
/// Errors: `line_ids` of another length than `uv`, a non-finite coordinate, a gap factor
/// that is not positive, an [`Error::OutOfMemory`] for the lines. O(n log n) for the grouping (O(n) when ids never decrease).
pub fn segment_lines(uv: &[[f64; 2]], line_ids: &[i64], gap_factor: f64) -> Result<ScanLines> {
    segment_lines_at(uv, line_ids, gap_factor, None)
}

/// [`segment_lines`] with the gaps of `median_step` when given (the median step of a whole
/// scan these points are some lines of) instead of the median of these points' steps.
/// Errors and time: those of [`segment_lines`].
pub fn segment_lines_at(
    uv: &[[f64; 2]],
    line_ids: &[i64],
    gap_factor: f64,
    median_step: Option<f64>,
) -> Result<ScanLines> {
    // The common case (all finite) in parallel; the serial check names the first bad one.
    let finite = |p: &[f64; 2]| p[0].is_finite() && p[1].is_finite();
    if uv.len() >= u32::MAX as usize || !uv.par_iter().with_min_len(BLOCK).all(finite) {
        crate::geometry::check_planar(uv)?;
    }
    check_gap_factor(gap_factor)?;
    if line_ids.len() != uv.len() {
        return Err(Error::InvalidParameter {
            name: "line_ids",
            value: format!("{} ids", line_ids.len()),
            expected: "one line id per point",
        });
    }
    if uv.len() > u32::MAX as usize {
        return Err(Error::InvalidParameter {
            name: "points",
            value: uv.len().to_string(),
            expected: "fewer than 2^32 points",
        });
    }
    // Input positions in line order: the input itself when ids never decrease (scans
    // usually come that way), else a stable sort (input order within a line).
    let sorted = line_ids
        .par_windows(2)
        .with_min_len(BLOCK)
        .all(|w| w[0] <= w[1]);
    const WHAT: &str = "the scan lines";
    let order: Vec<u32> = if sorted {
        Vec::new()
    } else {
        let mut order = try_collect(WHAT, 0..uv.len() as u32)?;
        order.par_sort_by_key(|&k| line_ids[k as usize]); // stable
        order
    };
    let at = |pos: usize| if sorted { pos as u32 } else { order[pos] };
    // Where each line starts in that order, then each line on its own, in parallel: its
    // points with coincident repeats dropped (each against the last point kept, as a
    // serial pass would), those repeats, and its step lengths (the median and the gaps
    // both need them). The same lines, repeats and steps as one serial pass.
    let starts = try_indices(WHAT, 0..uv.len(), |pos| {
        pos == 0 || line_ids[at(pos) as usize] != line_ids[at(pos - 1) as usize]
    })?;
    type Grouped = (Vec<u32>, Vec<(u32, u32)>, Vec<f64>);
    let mut grouped: Vec<Grouped> = try_filled(WHAT, Default::default(), starts.len())?;
    grouped.par_iter_mut().enumerate().try_for_each(
        |(l, (line, repeats, steps))| -> Result<()> {
            let end = starts.get(l + 1).copied().unwrap_or(uv.len());
            *line = try_vec(WHAT, end - starts[l])?;
            *steps = try_vec(WHAT, end - starts[l] - 1)?;
            line.push(at(starts[l]));
            for pos in starts[l] + 1..end {
                let (k, last) = (at(pos), *line.last().expect("lines are never empty"));
                let (p, q) = (uv[k as usize], uv[last as usize]);
                if p == q {
                    try_grow(WHAT, repeats, 1)?;
                    repeats.push((k, last));
                } else {
                    line.push(k);
                    steps.push(planar_distance(p, q));
                }
            }
            Ok(())
        },
    )?;
    let count = |part: fn(&Grouped) -> usize| grouped.iter().map(part).sum::<usize>();
    let mut duplicates = try_vec(WHAT, count(|g| g.1.len()))?;
    duplicates.extend(grouped.iter().flat_map(|g| g.1.iter().copied()));
    let median_step = match median_step {
        Some(step) => step,
        None => {
            let mut steps = try_vec("the steps", count(|g| g.2.len()))?;
            steps.extend(grouped.iter().flat_map(|g| g.2.iter().copied()));
            median_nonzero(steps)
        }
    };
    let gap = gap_factor * median_step;
    let lines = try_par_collect(
        WHAT,
        grouped.into_par_iter().map(|(line, _, steps)| {
            let mut segments = vec![vec![line[0]]];
            for (&k, &step) in line[1..].iter().zip(&steps) {
                if step > gap {
                    segments.push(Vec::new());
                }
                segments.last_mut().expect("one segment at least").push(k);
            }
            segments
        }),
    )?;
    Ok(ScanLines {
        lines,
        median_step,
        gap,
        duplicates,
    })
}

/// Steps on either side of a step over which [`split_at_jumps`] takes the local spacing:
/// the median of five steps ignores the jump itself and one more steep step beside it (a
/// point caught on the wall's face), where a point's own two steps would contain the jump.
pub const JUMP_WINDOW: usize = 2;

/// Splits the segments of `scan` where consecutive points jump in depth (a wall, a step,
/// the rim of a bore seen along the line): a step that is a jump by
/// [`crate::triangulate::jumps::is_depth_jump`] with factor `factor`, against the local spacing of
/// the
/// line there, the median 3-D step of the [`JUMP_WINDOW`] steps on either side of it and
/// itself. `points` are the 3-D points and `uv` their orthogonal projection in the same
/// units (as for [`crate::triangulate::jumps::DepthJumps`]); an infinite `factor` changes nothing.
/// Pieces
/// stay in scan order; strips then pair each piece with the overlapping pieces of the
/// neighbouring lines only. Errors: an [`Error::OutOfMemory`] for a line's steps or
/// pieces. O(n).
pub fn split_at_jumps(
    scan: &mut ScanLines,
    points: &[DVec3],
    uv: &[[f64; 2]],
    factor: f64,
) -> Result<()> {
    if !factor.is_finite() {
        return Ok(());
    }
    // Lengths in the unit box: no overflow at 1e300 or underflow at 1e-300.
    let norm = Normalizer::fit(points);
    let to_unit = if norm.half_extent > 0.0 {
        1.0 / norm.half_extent
    } else {
        1.0
    };
    let unit = |k: u32| norm.apply(points[k as usize]);
    const WHAT: &str = "the scan lines cut at depth jumps";
    // Appends the pieces of `segment` to `pieces`.
    let split = |segment: &[u32], pieces: &mut Vec<Vec<u32>>| -> Result<()> {
        let steps = segment
            .windows(2)
            .map(|w| (unit(w[1]) - unit(w[0])).length());
        let steps = try_collect(WHAT, steps)?;

        try_grow(WHAT, pieces, 1)?;
        pieces.push(vec![segment[0]]);
        let mut window = Vec::with_capacity(2 * JUMP_WINDOW + 1);
        for (i, &length3) in steps.iter().enumerate() {
            let lo = i.saturating_sub(JUMP_WINDOW);
            let hi = (i + JUMP_WINDOW + 1).min(steps.len());
            // The median is at least the window's shortest step (rounding is monotone): a
            // step no longer than `factor` times that is no jump, and on a smooth line no
            // step is, so the median and the planar length are taken only for the rest.
            let shortest = steps[lo..hi].iter().copied().fold(f64::INFINITY, f64::min);
            if length3 > factor * shortest {
                window.clear();
                window.extend_from_slice(&steps[lo..hi]);
                let mid = window.len() / 2;
                let spacing = *window.select_nth_unstable_by(mid, f64::total_cmp).1;
                let w = [segment[i], segment[i + 1]];
                let flat = planar_distance(uv[w[0] as usize], uv[w[1] as usize]) * to_unit;
                if crate::triangulate::jumps::is_depth_jump(length3, flat, spacing, factor) {
                    try_grow(WHAT, pieces, 1)?;
                    pieces.push(Vec::new());
                }
            }
            let piece = pieces.last_mut().expect("one piece at least");
            try_grow(WHAT, piece, 1)?;
            piece.push(segment[i + 1]);
        }
        Ok(())
    };
    scan.lines.par_iter_mut().try_for_each(|line| {
        let segments = std::mem::take(line);
        let mut pieces = try_vec(WHAT, segments.len())?;
        for segment in &segments {
            split(segment, &mut pieces)?;
        }
        *line = pieces;
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A raster (every line left to right) or zig-zag (alternating) scan of `rows` lines of
    /// `cols` points, spacing 1 along and `across` between lines, with optional jitter.
    fn scan(rows: usize, cols: usize, across: f64, zigzag: bool, jitter: f64) -> Vec<[f64; 2]> {
        let mut s = 5u64;
        let mut noise = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((s >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * jitter
        };
        let mut out = Vec::new();
        for r in 0..rows {
            for c in 0..cols {
                let c = if zigzag && r % 2 == 1 {
                    cols - 1 - c
                } else {
                    c
                };
                out.push([c as f64 + noise(), r as f64 * across + noise()]);
            }
        }
        out
    }

    fn expected(rows: usize, cols: usize) -> Vec<u32> {
        (0..rows * cols).map(|k| (k / cols) as u32).collect()
    }

    #[test]
    fn raster_and_zigzag_scans_are_found() {
        for across in [0.3, 1.0, 2.5, 10.0] {
            for zigzag in [false, true] {
                let uv = scan(7, 20, across, zigzag, 0.2);
                let ids = detect_lines(&uv, DEFAULT_GAP_FACTOR).unwrap();
                assert_eq!(ids, expected(7, 20), "across {across} zigzag {zigzag}");
            }
        }
    }

    #[test]
    fn a_zigzag_turn_point_starts_the_next_line() {
        // Line 0 to the right, a sideways move, line 1 to the left.
        let uv = vec![
            [0.0, 0.0],
            [1.0, 0.0],
            [2.0, 0.0],
            [2.0, 1.0],
            [1.0, 1.0],
            [0.0, 1.0],
        ];
        assert_eq!(detect_lines(&uv, 4.0).unwrap(), vec![0, 0, 0, 1, 1, 1]);
    }

    #[test]
    fn a_gap_along_the_line_is_not_a_new_line_but_splits_it() {
        let mut uv = scan(3, 20, 1.0, false, 0.0);
        uv.retain(|p| !(p[1] == 1.0 && p[0] > 5.0 && p[0] < 12.0));
        let ids = detect_lines(&uv, 4.0).unwrap();
        assert_eq!(*ids.iter().max().unwrap(), 2);
        let ids64: Vec<i64> = ids.iter().map(|&x| x as i64).collect();
        let lines = segment_lines(&uv, &ids64, 4.0).unwrap();
        assert_eq!(lines.lines.len(), 3);
        assert_eq!(lines.lines[1].len(), 2, "the holed line has two segments");
        assert_eq!(lines.lines[0].len(), 1);
        assert!((lines.median_step - 1.0).abs() < 1e-12);
    }

    #[test]
    fn explicit_ids_group_in_input_order_and_ascending_id() {
        let uv = vec![
            [0.0, 1.0],
            [0.0, 0.0],
            [1.0, 1.0],
            [1.0, 0.0],
            [2.0, 0.0],
            [2.0, 0.0],
        ];
        let ids = vec![7, -3, 7, -3, -3, -3];
        let lines = segment_lines(&uv, &ids, 4.0).unwrap();
        assert_eq!(lines.lines, vec![vec![vec![1, 3, 4]], vec![vec![0, 2]]]);
        assert_eq!(lines.duplicates, vec![(5, 4)]);
    }

    /// The parallel grouping against the serial pass it replaced (lines in ascending id,
    /// input order within a line, a point equal to the last one kept dropped), on random
    /// ids with many repeats, sorted and not, on pools of 1 and 3 threads.
    #[test]
    fn grouping_matches_a_serial_pass() {
        let mut s = 9u64;
        let mut next = |k: u64| {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 33) % k
        };
        for sorted in [false, true] {
            let n = 5000;
            let uv: Vec<[f64; 2]> = (0..n).map(|_| [next(4) as f64, next(3) as f64]).collect();
            let mut ids: Vec<i64> = (0..n).map(|_| next(40) as i64 - 20).collect();
            if sorted {
                ids.sort_unstable();
            }
            let mut order: Vec<usize> = (0..n).collect();
            order.sort_by_key(|&k| ids[k]);
            let (mut lines, mut duplicates): (Vec<Vec<u32>>, Vec<(u32, u32)>) = (vec![], vec![]);
            for (pos, &k) in order.iter().enumerate() {
                if pos == 0 || ids[k] != ids[order[pos - 1]] {
                    lines.push(vec![k as u32]);
                } else {
                    let last = *lines.last().unwrap().last().unwrap();
                    if uv[k] == uv[last as usize] {
                        duplicates.push((k as u32, last));
                    } else {
                        lines.last_mut().unwrap().push(k as u32);
                    }
                }
            }
            for threads in [1, 3] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .unwrap();
                let scan = pool.install(|| segment_lines(&uv, &ids, 1e9).unwrap());
                let joined: Vec<Vec<u32>> = scan.lines.iter().map(|l| l.concat()).collect();
                assert_eq!(joined, lines);
                assert_eq!(scan.duplicates, duplicates);
            }
        }
    }

    /// One line of 20 points along x, z given per point.
    fn profile(z: impl Fn(f64) -> f64) -> (Vec<DVec3>, Vec<[f64; 2]>, ScanLines) {
        let pts: Vec<DVec3> = (0..20)
            .map(|i| DVec3::new(i as f64, 0.0, z(i as f64)))
            .collect();
        let uv: Vec<[f64; 2]> = pts.iter().map(|p| [p.x, p.y]).collect();
        let scan = segment_lines(&uv, &[0; 20], DEFAULT_GAP_FACTOR).unwrap();
        (pts, uv, scan)
    }

    #[test]
    fn lines_are_cut_at_depth_jumps_only() {
        let factor = crate::triangulate::jumps::DEFAULT_JUMP_FACTOR;
        // A step 5 high between x = 9 and 10, and a bore 4 deep from x = 13 to 15.
        let (pts, uv, mut scan) = profile(|x| {
            let step = if x >= 10.0 { 5.0 } else { 0.0 };
            let bore = if (13.0..=15.0).contains(&x) {
                -4.0
            } else {
                0.0
            };
            step + bore + 0.1 * x.sin()
        });
        split_at_jumps(&mut scan, &pts, &uv, factor).unwrap();
        let cuts: Vec<u32> = scan.lines[0].iter().skip(1).map(|s| s[0]).collect();
        assert_eq!(cuts, vec![10, 13, 16]);
        assert_eq!(scan.lines[0].concat(), (0..20).collect::<Vec<u32>>());
        // A slope of 60° with even steps, and a step of 2 over a step of 1 in the plane
        // (2.2 spacings: under the factor), are no jumps; nor is anything at factor ∞.
        for z in [|x: f64| 1.7 * x, |x: f64| if x >= 10.0 { 2.0 } else { 0.0 }] {
            let (pts, uv, mut scan) = profile(z);
            let before = scan.clone();
            split_at_jumps(&mut scan, &pts, &uv, factor).unwrap();
            assert_eq!(scan, before);
        }
        let (pts, uv, mut scan) = profile(|x| if x >= 10.0 { 50.0 } else { 0.0 });
        let before = scan.clone();
        split_at_jumps(&mut scan, &pts, &uv, f64::INFINITY).unwrap();
        assert_eq!(scan, before);
        split_at_jumps(&mut scan, &pts, &uv, factor).unwrap();
        assert_eq!(scan.lines[0].len(), 2);
    }

    #[test]
    fn single_points_and_bad_input() {
        assert_eq!(detect_lines(&[[1.0, 2.0]], 4.0).unwrap(), vec![0]);
        assert!(detect_lines(&[], 4.0).unwrap().is_empty());
        assert!(detect_lines(&[[0.0, f64::NAN]], 4.0).is_err());
        assert!(detect_lines(&[[0.0, 0.0]], 0.0).is_err());
        assert!(segment_lines(&[[0.0, 0.0]], &[0, 1], 4.0).is_err());
        let one = segment_lines(&[[0.0, 0.0], [5.0, 5.0]], &[0, 1], 4.0).unwrap();
        assert_eq!(one.median_step, 0.0);
        assert_eq!(one.lines.len(), 2);
    }
}
