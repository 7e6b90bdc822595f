//! Where a ray without a return meets the measured nodes, found cheaply: the carving marches
//! each such ray from the scanner in half-voxel steps until the nearest node is measured
//! (`Volume::carve`'s stops), and most steps are far from any measured node.
//!
//! [`Reach`] holds, per cell of [`CELL`]³ nodes, its Chebyshev distance in cells to the
//! nearest cell holding a measured node (so a ray skips as many steps at once as that
//! distance allows, [`skip`]), and, per block holding one, a bit per node (so a step near
//! the surface reads one word, not the node's distance, weight and flags). The measured
//! nodes do not change while views are carved, so one `Reach` serves every view.

use super::blocks::{Blocks, Layout, BLOCK, BLOCK_NODES};
use crate::budget;
use crate::error::Result;
use rayon::prelude::*;

/// The largest distance (in blocks) a [`Reach`] records: farther counts as this far.
pub(super) const FAR: u8 = u8::MAX;

/// Nodes along each side of a cell of the distances.
const CELL: usize = 2;

/// Words of a block's bits, one bit per node.
const WORDS: usize = BLOCK_NODES / 64;

/// The measured nodes of a grid, for marching rays through it.
#[derive(Debug, Clone)]
pub(super) struct Reach {
    layout: Layout,
    /// Cells along x, y, z.
    cells: [usize; 3],
    /// Per cell (x fastest): cells to the nearest cell with a measured node, at most
    /// [`FAR`] (0: it has one).
    distance: Vec<u8>,
    /// Per block: its bits' place in `bits`, or `u32::MAX` when no node of it is measured.
    at: Vec<u32>,
    /// Per block with a measured node: a bit per node, in the block's node order.
    bits: Vec<[u64; WORDS]>,
}

impl Reach {
    /// The nodes of `blocks` for which `measured` (given a node's index into the slots'
    /// arrays, `Blocks::sum` and its kin) holds; only blocks with distances can hold one.
    /// O(nodes / [`CELL`]³ + allocated nodes), the nodes' part on every core; 1 byte per
    /// cell and 64 per block with a measured node.
    ///
    /// Errors: `OutOfMemory`.
    pub(super) fn new(blocks: &Blocks, measured: impl Fn(usize) -> bool + Sync) -> Result<Self> {
        let layout = blocks.layout();
        let slot_bits: Vec<[u64; WORDS]> = budget::try_par_collect(
            "the measured nodes",
            (0..blocks.owner.len()).into_par_iter().map(|s| {
                let mut w = [0u64; WORDS];
                for n in 0..BLOCK_NODES {
                    if measured(s * BLOCK_NODES + n) {
                        w[n / 64] |= 1 << (n % 64);
                    }
                }
                w
            }),
        )?;
        let mut at = budget::try_filled("the measured blocks", u32::MAX, blocks.len())?;
        let mut bits = budget::try_vec("the measured nodes", 0)?;
        for (s, w) in slot_bits.iter().enumerate() {
            if w.iter().any(|&x| x != 0) {
                budget::try_grow("the measured nodes", &mut bits, 1)?;
                at[blocks.owner[s] as usize] = bits.len() as u32;
                bits.push(*w);
            }
        }
        drop(slot_bits);
        let dims = layout.dims();
        let cells = dims.map(|d| d.div_ceil(CELL));
        let mut distance = budget::try_filled("the measured cells", FAR, cells.iter().product())?;
        for (b, &a) in at.iter().enumerate() {
            if a == u32::MAX {
                continue;
            }
            let [lo, _] = layout.nodes(b);
            let words = &bits[a as usize];
            for n in (0..BLOCK_NODES).filter(|&n| words[n / 64] & (1 << (n % 64)) != 0) {
                let local = [n % BLOCK, (n / BLOCK) % BLOCK, n / (BLOCK * BLOCK)];
                let c: [usize; 3] = std::array::from_fn(|x| (lo[x] + local[x]) / CELL);
                distance[(c[2] * cells[1] + c[1]) * cells[0] + c[0]] = 0;
            }
        }
        chessboard(&mut distance, cells);
        Ok(Self {
            layout,
            cells,
            distance,
            at,
            bits,
        })
    }

    /// Cells from the cell of node (i, j, k) to the nearest cell with a measured node, at
    /// most [`FAR`]. O(1).
    pub(super) fn distance(&self, node: [usize; 3]) -> u8 {
        let [cx, cy, _] = self.cells;
        let c = node.map(|v| v / CELL);
        self.distance[(c[2] * cy + c[1]) * cx + c[0]]
    }

    /// Whether node (i, j, k) is measured. O(1).
    pub(super) fn measured(&self, node: [usize; 3]) -> bool {
        let (b, local) = self.layout.locate(node);
        let a = self.at[b];
        a != u32::MAX && self.bits[a as usize][local / 64] & (1 << (local % 64)) != 0
    }
}

/// Half-voxel steps a ray may take at once from a step whose nearest node's cell lies
/// `d` ≥ 2 cells from every cell with a measured node: none of the nearest nodes of the
/// steps passed over is measured.
///
/// Why: after k steps of half a voxel the point has moved at most k/2 voxels along each
/// axis, so its nearest node at most ⌈k/2⌉ nodes, one more allowed for the rounding of a
/// point near a half; from anywhere in a cell, t nodes reach at most ⌊(CELL − 1 + t) /
/// CELL⌋ cells away, under d while t ≤ CELL (d − 1), which holds for k ≤ 2 CELL (d − 1) − 3.
pub(super) fn skip(d: u8) -> usize {
    debug_assert!(d >= 2);
    2 * CELL * (usize::from(d) - 1) - 2
}

/// Replaces `distance` (0 at the sources, [`FAR`] elsewhere, on a grid of `counts` x
/// fastest) by each entry's Chebyshev (chessboard) distance to the nearest source, at most
/// [`FAR`]: two raster passes, each taking the minimum over the 13 neighbours already
/// passed plus one (Rosenfeld & Pfaltz 1966; exact for this metric). O(entries).
fn chessboard(distance: &mut [u8], [nx, ny, nz]: [usize; 3]) {
    let at = |x: usize, y: usize, z: usize| (z * ny + y) * nx + x;
    let pass = |distance: &mut [u8], forward: bool| {
        for z in 0..nz {
            for y in 0..ny {
                for x in 0..nx {
                    let (x, y, z) = if forward {
                        (x, y, z)
                    } else {
                        (nx - 1 - x, ny - 1 - y, nz - 1 - z)
                    };
                    let mut best = distance[at(x, y, z)];
                    if best == 0 {
                        continue;
                    }
                    // the neighbours before this entry in the pass's order: the previous
                    // layer's 9, the previous row's 3, the previous entry
                    let back = |v: usize, n: usize, o: isize| -> Option<usize> {
                        let o = if forward { o } else { -o };
                        let w = v as isize + o;
                        (w >= 0 && (w as usize) < n).then_some(w as usize)
                    };
                    let mut near = |dx: isize, dy: isize, dz: isize| {
                        if let (Some(a), Some(b), Some(c)) =
                            (back(x, nx, dx), back(y, ny, dy), back(z, nz, dz))
                        {
                            best = best.min(distance[at(a, b, c)].saturating_add(1));
                        }
                    };
                    for dy in -1..=1 {
                        for dx in -1..=1 {
                            near(dx, dy, -1);
                        }
                    }
                    for dx in -1..=1 {
                        near(dx, -1, 0);
                    }
                    near(-1, 0, 0);
                    distance[at(x, y, z)] = best;
                }
            }
        }
    };
    pass(distance, true);
    pass(distance, false);
}

/// `x.round()` (half away from zero) without a call into libm where the target lacks a
/// rounding instruction (x86-64 before SSE4.1: that call was a tenth of merge's time):
/// the integer part by conversion and the fraction are exact below 2⁵², and larger
/// values are integers already. Equal to `x.round()` for every `x`.
#[inline]
pub(super) fn round(x: f64) -> f64 {
    if x.is_nan() || x.abs() >= 4_503_599_627_370_496.0 {
        return x.round(); // 2^52 or more, infinite or NaN: nothing to round
    }
    let t = (x as i64) as f64;
    let f = x - t;
    if f >= 0.5 {
        t + 1.0
    } else if f <= -0.5 {
        t - 1.0
    } else if t == 0.0 {
        // keep the sign of a zero result, as round does (-0.3 rounds to -0.0)
        0.0_f64.copysign(x)
    } else {
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    #[test]
    fn rounding_matches_the_standard_library() {
        let mut values = vec![
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.5,
            -1.5,
            2.5,
            0.49999999999999994,
            -0.49999999999999994,
            4503599627370495.5,
            -4503599627370495.5,
            4503599627370497.0,
            1e300,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::MIN_POSITIVE,
        ];
        let mut s = 0x9e37_79b9_7f4a_7c15_u64;
        for _ in 0..100_000 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let x = (s >> 11) as f64 / (1u64 << 53) as f64;
            values.push((x - 0.5) * 2000.0);
            values.push(((x - 0.5) * 2000.0).floor() + 0.5);
        }
        for x in values {
            assert_eq!(round(x).to_bits(), x.round().to_bits(), "{x}");
        }
        assert!(round(f64::NAN).is_nan());
    }

    #[test]
    fn chessboard_distances_match_a_brute_force() {
        let counts = [11, 9, 7];
        let n = 11 * 9 * 7;
        let xyz = |i: usize| [i % 11, (i / 11) % 9, i / 99];
        for sources in [
            vec![3, 41, 137],
            vec![0],
            vec![n - 1, 500, 250, 251],
            vec![],
        ] {
            let mut d: Vec<u8> = (0..n)
                .map(|i| if sources.contains(&i) { 0 } else { FAR })
                .collect();
            chessboard(&mut d, counts);
            for (i, &v) in d.iter().enumerate() {
                let want = sources
                    .iter()
                    .map(|&s| (0..3).map(|a| xyz(i)[a].abs_diff(xyz(s)[a])).max().unwrap())
                    .min()
                    .map_or(FAR, |m| m as u8);
                assert_eq!(v, want, "{:?} from {sources:?}", xyz(i));
            }
        }
    }

    #[test]
    fn a_skip_passes_over_no_node_of_a_nearer_cell() {
        // a ray along a diagonal and along an axis, from points anywhere in a cell
        for d in 2..=FAR {
            let m = skip(d);
            for dir in [
                DVec3::X,
                DVec3::ONE.normalize(),
                DVec3::new(0.3, -0.9, 0.1).normalize(),
            ] {
                for start in [0.0, 0.49, 0.51, 0.99, 1.49, 1.51] {
                    let p0 = DVec3::splat(1000.0 + start);
                    let c0 = (p0.round() / CELL as f64).floor();
                    for k in 0..m {
                        let p = p0 + dir * (0.5 * k as f64);
                        let c = (p.round() / CELL as f64).floor();
                        assert!((c - c0).abs().max_element() < f64::from(d), "d {d} k {k}");
                    }
                }
            }
        }
    }
}
