//! Memory locality: a relabelling of vertices and triangles along a space-filling curve.
//!
//! Annealing proposes edges uniformly at random, so each proposal starts with one cache
//! miss; everything it touches next (the two triangles, four corners, their positions and
//! angle sums) should then be nearby. Scan order is only coherent along lines, spade's face
//! order is its own; a Z-order (Morton) relabelling makes both local at every scale, which
//! matters once the arrays outgrow the caches (a 1M-point scan holds about 250 MB of state).
//! Delaunay's sweep wants another order, outwards from the centre ([`sweep_order`]).

use crate::budget::{try_collect, try_filled, try_par_collect};
use crate::Result;
use rayon::prelude::*;

/// Hints the CPU to bring the cache line holding `slice[i]` into L1 (`prefetcht0`). No
/// effect on results, only on when memory is read; a no-op off x86-64. An index out of
/// range is harmless (a prefetch never faults), so there is no bounds check. O(1), never
/// blocks.
///
/// Why: annealing draws its edges from the RNG ahead of time, independently of the state
/// ([`crate::optimize::anneal`]), so the lines a proposal will read can be requested several
/// proposals early and their misses overlap instead of forming one dependent chain.
#[inline(always)]
#[allow(unsafe_code)]
pub fn prefetch<T>(slice: &[T], i: usize) {
    // `wrapping_add` is safe and computes the address only; nothing is dereferenced.
    let p = slice.as_ptr().wrapping_add(i);
    #[cfg(target_arch = "x86_64")]
    // SAFETY: `_mm_prefetch` is a hint that never faults and reads nothing into registers,
    // whatever the address; SSE is part of the x86-64 baseline.
    unsafe {
        use core::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        _mm_prefetch::<_MM_HINT_T0>(p.cast::<i8>());
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = p;
}

/// Indices of `uv` (finite planar points) in order of distance from the centre of their
/// bounding box, ties (and distances closer than the key's 2^-32 resolution) by index.
///
/// The order in which delaunator's circle sweep inserts points, approximately (it starts at
/// the point nearest that centre): triangulating points relabelled in this order makes its
/// accesses, and those of every later pass over its triangles, walk memory forwards
/// instead of jumping across the scan, which at 10M points (hundreds of MB per array)
/// costs more than the arithmetic. Exact copies of a point stay in input order. O(n log n),
/// sorted on the rayon pool (the order does not depend on the thread count). Errors: an
/// [`crate::Error::OutOfMemory`] for the keys or the order.
pub fn sweep_order(uv: &[[f64; 2]]) -> Result<Vec<u32>> {
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in uv {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    // Halves before sums: no overflow at 1e308.
    let centre = [0, 1].map(|k| lo[k] * 0.5 + hi[k] * 0.5);
    let reach = [0, 1].map(|k| (hi[k] * 0.5 - lo[k] * 0.5).max(f64::MIN_POSITIVE));
    let distance = |p: &[f64; 2]| {
        let (x, y) = ((p[0] - centre[0]) / reach[0], (p[1] - centre[1]) / reach[1]);
        // In [0, 1]: the bounding box's corners are at 2, one half scales that to 1.
        ((x * x + y * y) * 0.5).min(1.0)
    };
    const WHAT: &str = "the sweep order";
    let keys = uv
        .par_iter()
        .with_min_len(1 << 14)
        .enumerate()
        .map(|(i, p)| (((distance(p) * u32::MAX as f64) as u64) << 32) | i as u64);
    let mut keyed = try_par_collect(WHAT, keys)?;
    keyed.par_sort_unstable();
    try_collect(WHAT, keyed.into_iter().map(|k| k as u32))
}

/// A permutation of vertex indices and the inverse, plus helpers to move data across it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Relabel {
    /// `to_local[input] = local`.
    pub to_local: Vec<u32>,
    /// `to_input[local] = input`.
    pub to_input: Vec<u32>,
}

/// Spreads the low 32 bits of `x` to the even bits of a u64. O(1).
#[inline]
fn spread(x: u64) -> u64 {
    let mut x = x & 0xffff_ffff;
    x = (x | (x << 16)) & 0x0000_ffff_0000_ffff;
    x = (x | (x << 8)) & 0x00ff_00ff_00ff_00ff;
    x = (x | (x << 4)) & 0x0f0f_0f0f_0f0f_0f0f;
    x = (x | (x << 2)) & 0x3333_3333_3333_3333;
    (x | (x << 1)) & 0x5555_5555_5555_5555
}

impl Relabel {
    /// Orders vertices by the Morton code of their planar position (ties by input index,
    /// so the result is deterministic). Errors: an [`crate::Error::OutOfMemory`] for the
    /// keys or the permutation. O(n log n).
    pub fn morton(uv: &[[f64; 2]]) -> Result<Relabel> {
        const WHAT: &str = "the Z-order relabelling";
        let (unit, _) = crate::geometry::normalize_plane(uv);
        let cell = |x: f64| (((x + 1.0) * 0.5).clamp(0.0, 1.0) * u32::MAX as f64) as u64;
        let keys = unit
            .iter()
            .enumerate()
            .map(|(i, p)| (spread(cell(p[0])) | (spread(cell(p[1])) << 1), i as u32));
        let mut keyed = try_collect(WHAT, keys)?;
        drop(unit);
        keyed.sort_unstable();
        let to_input = try_collect(WHAT, keyed.into_iter().map(|(_, i)| i))?;
        let mut to_local = try_filled(WHAT, 0u32, to_input.len())?;
        for (local, &input) in to_input.iter().enumerate() {
            to_local[input as usize] = local as u32;
        }
        Ok(Relabel { to_local, to_input })
    }

    /// Per-vertex data in local order. Errors: an [`crate::Error::OutOfMemory`] for the
    /// copy. O(n).
    pub fn vertices<T: Copy>(&self, input: &[T]) -> Result<Vec<T>> {
        let local = self.to_input.iter().map(|&i| input[i as usize]);
        try_collect("the vertices in local order", local)
    }

    /// Triangles in local indices, sorted by their smallest local vertex so that triangles
    /// (and with them half-edge slots) follow the curve too. Orientation is kept. Errors:
    /// an [`crate::Error::OutOfMemory`] for the copy. O(m log m).
    pub fn triangles_to_local(&self, triangles: &[[u32; 3]]) -> Result<Vec<[u32; 3]>> {
        let local = triangles
            .iter()
            .map(|t| t.map(|v| self.to_local[v as usize]));
        let mut local = try_collect("the triangles in local indices", local)?;
        local.sort_unstable_by_key(|t| (*t.iter().min().expect("3 corners"), t[0], t[1], t[2]));
        Ok(local)
    }

    /// Triangles back in input indices. Errors: an [`crate::Error::OutOfMemory`] for the
    /// copy. O(m).
    pub fn triangles_to_input(&self, triangles: &[[u32; 3]]) -> Result<Vec<[u32; 3]>> {
        let input = triangles
            .iter()
            .map(|t| t.map(|v| self.to_input[v as usize]));
        try_collect("the triangles in input indices", input)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_locality() {
        let uv: Vec<[f64; 2]> = (0..64 * 64)
            .map(|k| [(k % 64) as f64, (k / 64) as f64])
            .collect();
        let r = Relabel::morton(&uv).unwrap();
        let back: Vec<u32> = r.to_input.iter().map(|&i| r.to_local[i as usize]).collect();
        assert_eq!(back, (0..uv.len() as u32).collect::<Vec<_>>());
        let tris = vec![[0u32, 1, 64], [1, 65, 64]];
        let local = r.triangles_to_local(&tris).unwrap();
        assert_eq!(r.triangles_to_input(&local).unwrap().len(), 2);
        let mut restored = r.triangles_to_input(&local).unwrap();
        restored.sort();
        assert_eq!(restored, vec![[0, 1, 64], [1, 65, 64]]);
        // On a grid, consecutive local labels are on average much closer than in row order.
        let local_uv = r.vertices(&uv).unwrap();
        let mean_step = |pts: &[[f64; 2]]| {
            pts.windows(2)
                .map(|w| (w[0][0] - w[1][0]).hypot(w[0][1] - w[1][1]))
                .sum::<f64>()
                / (pts.len() - 1) as f64
        };
        // Row order jumps 63 units at each row end; the Z-curve's long jumps are rarer.
        assert!(mean_step(&local_uv) < 2.0, "{}", mean_step(&local_uv));
        // Within any aligned 8x8 block, labels are contiguous.
        let block: Vec<u32> = (0..8)
            .flat_map(|j| (0..8).map(move |i| j * 64 + i))
            .map(|v| r.to_local[v as usize])
            .collect();
        assert_eq!(
            block.iter().max().unwrap() - block.iter().min().unwrap(),
            63
        );
    }
}
