//! Which strip triangles bridge a depth jump: [`bridging_triangles`], decided on the few
//! triangles that can.
//!
//! The rule drops a triangle whose longest 3-D edge is steep and longer than `factor` ×
//! the smallest local spacing of its corners, the local spacing of a vertex being the
//! median length of its edges (`triangulate::jumps::spacings`). A median is at least the
//! shortest of the lengths, so a triangle whose longest edge is at most `factor` × the
//! shortest edge at any of its corners cannot bridge a jump, steep or not; on a smooth scan
//! that is every triangle (compared as squares in the unit box, with a margin far above
//! their rounding; the 1M-point synthetic scan of `benches/peers.py`: a quarter of
//! its 2M triangles are steep, none is a candidate), and the medians (a sort of the edges
//! of every steep triangle's corners, a second of the strips' time there) are never taken.
//! The candidates left are judged by [`bridging_triangles`] itself, on the triangles around
//! their corners: that holds every edge at a candidate's corner, so their local spacings,
//! and the verdicts, are those over the whole mesh.

use crate::budget::{try_collect, try_filled, try_indices, try_par_collect};
use crate::geometry::{Normalizer, PAR_BLOCK};
use crate::triangulate::jumps::{bridging_triangles, infinities, lower, DepthJumps};
use crate::Result;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};

/// [`bridging_triangles`]`(uv, triangles, jumps)`, bit for bit, computed on the candidates
/// only (see the module docs). O(n + m) in parallel, plus that of [`bridging_triangles`]
/// on the candidates' neighbourhoods. Errors as [`bridging_triangles`].
pub(super) fn bridging(
    uv: &[[f64; 2]],
    triangles: &[[u32; 3]],
    jumps: DepthJumps,
) -> Result<Vec<bool>> {
    // The shortcut holds for the jump rule alone: the gap rule drops at any slope.
    debug_assert!(
        !jumps.gaps,
        "strips::jumps::bridging takes the jump rule only"
    );
    const WHAT: &str = "the strips' jump check";
    let none = || try_filled(WHAT, false, triangles.len());
    if !jumps.factor.is_finite() || triangles.is_empty() {
        return none();
    }
    // Squared lengths in the unit box (where `bridging_triangles` measures, so no square
    // overflows), each point mapped as its edge is read: no mapped copy of the points.
    let norm = Normalizer::fit(jumps.points);
    let to_unit = if norm.half_extent > 0.0 {
        1.0 / norm.half_extent
    } else {
        1.0
    };
    // The filter compares squares with a relative margin of 1e-9, far above the rounding
    // that separates these lengths from the rule's (a few ulps), so every triangle the
    // rule drops is a candidate; a square that underflows (an edge below 1e-150 of the
    // scan's extent) makes its triangle a candidate. Where the margin's factor² would
    // overflow or the scale is not a normal number, every triangle is a candidate.
    let k = jumps.factor * jumps.factor * (1.0 - 1e-9);
    if !(k.is_finite() && to_unit.is_normal()) {
        return bridging_triangles(uv, triangles, jumps);
    }
    let unit = |v: u32| (jumps.points[v as usize] - norm.center) * to_unit;
    let edges = |t: &[u32; 3]| {
        let [a, b, c] = t.map(unit);
        [
            (a - b).length_squared(),
            (b - c).length_squared(),
            (c - a).length_squared(),
        ]
    };
    // The shortest edge at each vertex, squared (squares are lengths ≥ +0 too).
    let shortest = infinities(WHAT, jumps.points.len())?;
    triangles.par_iter().with_min_len(PAR_BLOCK).for_each(|t| {
        let squares = edges(t);
        for (e, &l2) in squares.iter().enumerate() {
            for v in [t[e], t[(e + 1) % 3]] {
                lower(&shortest[v as usize], l2);
            }
        }
    });
    let is_candidate = |t: &[u32; 3]| {
        let longest = edges(t).into_iter().fold(0.0, f64::max);
        let nearest = t
            .iter()
            .map(|&v| f64::from_bits(shortest[v as usize].load(Ordering::Relaxed)))
            .fold(f64::INFINITY, f64::min);
        longest < 1e-300 || longest > k * nearest
    };
    // On a smooth scan there is none: then no list is made.
    if !triangles
        .par_iter()
        .with_min_len(PAR_BLOCK)
        .any(is_candidate)
    {
        return none();
    }
    let candidate = triangles
        .par_iter()
        .with_min_len(PAR_BLOCK)
        .map(is_candidate);
    let candidate = try_par_collect(WHAT, candidate)?;
    // Every triangle at a candidate's corner, so that their spacings are whole.
    let corner = (0..jumps.points.len())
        .into_par_iter()
        .with_min_len(PAR_BLOCK)
        .map(|_| AtomicBool::new(false));
    let corner = try_par_collect(WHAT, corner)?;
    triangles.par_iter().zip(&candidate).for_each(|(t, &c)| {
        if c {
            t.iter()
                .for_each(|&v| corner[v as usize].store(true, Ordering::Relaxed));
        }
    });
    let around = try_indices(WHAT, 0..triangles.len(), |f| {
        triangles[f]
            .iter()
            .any(|&v| corner[v as usize].load(Ordering::Relaxed))
    })?;
    let near = try_collect(WHAT, around.iter().map(|&f| triangles[f]))?;
    let verdicts = bridging_triangles(uv, &near, jumps)?;
    let mut bridges = none()?;
    for (&f, bridge) in around.iter().zip(verdicts) {
        // Others around them may see partial spacings; they are not candidates anyway.
        bridges[f] = bridge && candidate[f];
    }
    Ok(bridges)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    /// A deterministic generator for test data (LCG, top 53 bits).
    fn lcg(state: &mut u64) -> f64 {
        *state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (*state >> 11) as f64 / (1u64 << 53) as f64
    }

    /// A grid of `w` × `h` points with height `z(x, y)`, triangulated two triangles per
    /// cell, with jittered positions.
    fn grid(
        w: usize,
        h: usize,
        seed: u64,
        z: impl Fn(f64, f64) -> f64,
    ) -> (Vec<DVec3>, Vec<[f64; 2]>, Vec<[u32; 3]>) {
        let mut s = seed;
        let mut points = Vec::new();
        for j in 0..h {
            for i in 0..w {
                let (x, y) = (i as f64 + 0.1 * lcg(&mut s), j as f64 + 0.1 * lcg(&mut s));
                points.push(DVec3::new(x, y, z(x, y)));
            }
        }
        let uv = points.iter().map(|p| [p.x, p.y]).collect();
        let mut tris = Vec::new();
        for j in 0..h - 1 {
            for i in 0..w - 1 {
                let k = (j * w + i) as u32;
                let (a, b, c, d) = (k, k + 1, k + w as u32, k + w as u32 + 1);
                tris.push([a, b, d]);
                tris.push([a, d, c]);
            }
        }
        (points, uv, tris)
    }

    #[test]
    fn bridging_is_bridging_triangles_bit_for_bit() {
        // Smooth (no candidate), steep but smooth (steep triangles, no candidate), walls and
        // spikes (candidates), at several factors.
        let shapes: [&dyn Fn(f64, f64) -> f64; 4] = [
            &|x, y| 0.1 * (x + y),
            &|x, y| 3.0 * x + (0.3 * y).sin(),
            &|x, _| if x > 20.5 { 12.0 } else { 0.0 },
            &|x, y| {
                if (x as i64 * 7 + y as i64 * 3) % 17 == 0 {
                    9.0
                } else {
                    0.2 * y
                }
            },
        ];
        let mut dropped = 0;
        // Scales far from 1 (the filter squares lengths in the unit box) and a factor whose
        // square overflows.
        for (seed, z, scale) in (0..3).flat_map(|s| {
            shapes
                .iter()
                .enumerate()
                .map(move |(k, z)| (k, z, [1.0, 1e-200, 1e200][s]))
        }) {
            let (mut points, uv, tris) = grid(40, 30, seed as u64 + 1, z);
            points.iter_mut().for_each(|p| *p *= scale);
            for factor in [1.5, 3.0, 8.0, 1e160, f64::INFINITY] {
                let jumps = DepthJumps {
                    points: &points,
                    factor,
                    gaps: false,
                };
                let fast = bridging(&uv, &tris, jumps).unwrap();
                assert_eq!(
                    fast,
                    bridging_triangles(&uv, &tris, jumps).unwrap(),
                    "shape {seed}, scale {scale}, factor {factor}"
                );
                dropped += fast.iter().filter(|&&b| b).count();
            }
        }
        assert!(dropped > 0, "the walls and spikes must drop triangles");
    }
}
