//! The k nearest neighbours of planar points, found in a uniform grid of buckets.
//!
//! The noise estimate fits a quadric to each point's nearest neighbours in the plane; a
//! k-d tree from scipy did the search, and importing it cost a fresh process about 0.2 CPU
//! seconds, more than the search itself on the scans the default meshes in about a second.
//! Scan points are spread evenly enough over their plane that buckets of about two points
//! each find any point's neighbours in a few rings of cells.

use crate::budget::{try_filled, try_vec};
use crate::{Error, Result};
use rayon::prelude::*;

/// Points per bucket the grid aims at: fewer means more empty cells to walk, more means
/// more distances per ring.
const POINTS_PER_CELL: f64 = 2.0;

/// Queries given to one task: enough to pay for the task, few enough to balance two cores.
const QUERY_BLOCK: usize = 256;

/// For each point `queries[i]` of `points` (planar, finite), the indices of its `k`
/// nearest points of `points` (itself included), nearest first, ties by the smaller index:
/// row `i` of the returned `queries.len() * k` indices, row-major.
///
/// Errors: a non-finite coordinate ([`Error::NonFinite`]), `k` of 0 or more than the
/// points ([`Error::InvalidParameter`]), a query index out of range, memory refused.
/// O(N + Q · k log k) for points spread over their bounding box (Q queries), on every
/// core; a query among points crowded into few cells pays for the crowd.
pub fn k_nearest(points: &[[f64; 2]], queries: &[usize], k: usize) -> Result<Vec<u32>> {
    if let Some((index, axis, value)) = first_non_finite(points) {
        return Err(Error::NonFinite { index, axis, value });
    }
    if k == 0 || k > points.len() {
        return Err(Error::InvalidParameter {
            name: "k",
            value: k.to_string(),
            expected: "from 1 to the number of points",
        });
    }
    if let Some(&bad) = queries.iter().find(|&&q| q >= points.len()) {
        return Err(Error::InvalidParameter {
            name: "queries",
            value: bad.to_string(),
            expected: "indices of the points",
        });
    }
    let grid = Buckets::new(points)?;
    let mut out = try_filled("the neighbours' indices", 0u32, queries.len() * k)?;
    out.par_chunks_mut(QUERY_BLOCK * k)
        .zip(queries.par_chunks(QUERY_BLOCK))
        .for_each(|(rows, block)| {
            let mut best: Vec<(f64, u32)> = Vec::with_capacity(4 * k);
            for (row, &q) in rows.chunks_mut(k).zip(block) {
                grid.nearest(points, points[q], k, &mut best);
                for (slot, &(_, i)) in row.iter_mut().zip(&best) {
                    *slot = i;
                }
            }
        });
    Ok(out)
}

/// The first non-finite coordinate as (point, axis, value).
fn first_non_finite(points: &[[f64; 2]]) -> Option<(usize, usize, f64)> {
    points.iter().enumerate().find_map(|(index, p)| {
        (0..2)
            .find(|&axis| !p[axis].is_finite())
            .map(|axis| (index, axis, p[axis]))
    })
}

/// The points sorted into square cells of a grid over their bounding box: the points of
/// cell `c` are `order[start[c]..start[c + 1]]`.
struct Buckets {
    origin: [f64; 2],
    cell: f64,
    columns: usize,
    rows: usize,
    start: Vec<u32>,
    order: Vec<u32>,
}

impl Buckets {
    /// Counting sort of `points` into about N / [`POINTS_PER_CELL`] cells. O(N).
    fn new(points: &[[f64; 2]]) -> Result<Self> {
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in points {
            for a in 0..2 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
        let extent = [hi[0] - lo[0], hi[1] - lo[1]];
        let target = (points.len() as f64 / POINTS_PER_CELL).max(1.0);
        // Points along a line have no area: their cells are cut along the line's length.
        let by_area = (extent[0] * extent[1] / target).sqrt();
        let by_length = extent[0].max(extent[1]) / target;
        let mut cell = by_area.max(by_length);
        if !(cell.is_finite() && cell > 0.0) {
            cell = 1.0; // every point at one spot
        }
        let span = |e: f64| ((e / cell).floor() as usize).saturating_add(1);
        let (columns, rows) = (span(extent[0]), span(extent[1]));
        let cells = columns * rows;
        let mut grid = Buckets {
            origin: lo,
            cell,
            columns,
            rows,
            start: try_filled("the neighbour grid's cells", 0u32, cells + 1)?,
            order: try_vec("the neighbour grid's points", points.len())?,
        };
        for p in points {
            let c = grid.cell_of(*p);
            grid.start[c + 1] += 1;
        }
        for c in 0..cells {
            grid.start[c + 1] += grid.start[c];
        }
        let mut fill = grid.start.clone();
        grid.order.resize(points.len(), 0);
        for (i, p) in points.iter().enumerate() {
            let c = grid.cell_of(*p);
            grid.order[fill[c] as usize] = i as u32;
            fill[c] += 1;
        }
        Ok(grid)
    }

    /// Column and row of the cell holding `p`, clamped to the grid.
    fn column_row(&self, p: [f64; 2]) -> (usize, usize) {
        let at = |a: usize, last: usize| {
            (((p[a] - self.origin[a]) / self.cell).floor().max(0.0) as usize).min(last - 1)
        };
        (at(0, self.columns), at(1, self.rows))
    }

    fn cell_of(&self, p: [f64; 2]) -> usize {
        let (c, r) = self.column_row(p);
        r * self.columns + c
    }

    /// The `k` nearest points to `at` into `best` as (squared distance, index), sorted.
    /// Rings of cells around `at`'s cell are searched until the next ring cannot hold a
    /// nearer point than the k-th found.
    fn nearest(&self, points: &[[f64; 2]], at: [f64; 2], k: usize, best: &mut Vec<(f64, u32)>) {
        best.clear();
        let (c0, r0) = self.column_row(at);
        let widest = self.columns.max(self.rows);
        for ring in 0..widest {
            self.visit_ring(c0, r0, ring, |c| {
                let cell = (self.start[c] as usize)..(self.start[c + 1] as usize);
                for &i in &self.order[cell] {
                    let p = points[i as usize];
                    let (dx, dy) = (p[0] - at[0], p[1] - at[1]);
                    best.push((dx * dx + dy * dy, i));
                }
            });
            if best.len() >= 2 * k.max(8) || ring + 1 == widest {
                keep_nearest(best, k);
            }
            if best.len() >= k {
                // Any point in ring + 1 or beyond is at least `ring` whole cells away.
                let reach = ring as f64 * self.cell;
                let kth = best.iter().map(|b| b.0).fold(0.0_f64, f64::max);
                if reach * reach > kth {
                    break;
                }
            }
        }
        keep_nearest(best, k);
    }

    /// Calls `f` with every cell of the grid at Chebyshev distance `ring` from (c0, r0).
    fn visit_ring(&self, c0: usize, r0: usize, ring: usize, mut f: impl FnMut(usize)) {
        let (c0, r0, ring) = (c0 as isize, r0 as isize, ring as isize);
        let (columns, rows) = (self.columns as isize, self.rows as isize);
        let mut take = |c: isize, r: isize| {
            if (0..columns).contains(&c) && (0..rows).contains(&r) {
                f((r * columns + c) as usize);
            }
        };
        if ring == 0 {
            take(c0, r0);
            return;
        }
        for c in (c0 - ring)..=(c0 + ring) {
            take(c, r0 - ring);
            take(c, r0 + ring);
        }
        for r in (r0 - ring + 1)..(r0 + ring) {
            take(c0 - ring, r);
            take(c0 + ring, r);
        }
    }
}

/// `best` cut to its `k` nearest, sorted by distance, then index.
fn keep_nearest(best: &mut Vec<(f64, u32)>, k: usize) {
    let order = |a: &(f64, u32), b: &(f64, u32)| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1));
    if best.len() > k {
        best.select_nth_unstable_by(k - 1, order);
        best.truncate(k);
    }
    best.sort_unstable_by(order);
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand_core::{RngCore, SeedableRng};
    use rand_pcg::Pcg64;

    fn brute(points: &[[f64; 2]], q: usize, k: usize) -> Vec<u32> {
        let mut all: Vec<(f64, u32)> = points
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let (dx, dy) = (p[0] - points[q][0], p[1] - points[q][1]);
                (dx * dx + dy * dy, i as u32)
            })
            .collect();
        keep_nearest(&mut all, k);
        all.into_iter().map(|b| b.1).collect()
    }

    fn uniform(rng: &mut Pcg64) -> f64 {
        (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    #[test]
    fn agrees_with_brute_force_on_spread_clustered_and_collinear_points() {
        let mut rng = Pcg64::seed_from_u64(7);
        let spread: Vec<[f64; 2]> = (0..500)
            .map(|_| [uniform(&mut rng) * 30.0, uniform(&mut rng)])
            .collect();
        // two tight clusters far apart: most cells empty
        let clustered: Vec<[f64; 2]> = (0..400)
            .map(|i| {
                let off = if i % 2 == 0 { 0.0 } else { 1e4 };
                [off + uniform(&mut rng) * 1e-3, uniform(&mut rng) * 1e-3]
            })
            .collect();
        let line: Vec<[f64; 2]> = (0..300).map(|i| [i as f64 * 0.5, 2.0]).collect();
        // a lattice: many ties, broken by index
        let lattice: Vec<[f64; 2]> = (0..400)
            .map(|i| [(i % 20) as f64, (i / 20) as f64])
            .collect();
        for points in [&spread, &clustered, &line, &lattice] {
            for k in [1, 7, 13, 40] {
                let queries: Vec<usize> = (0..points.len()).step_by(3).collect();
                let found = k_nearest(points, &queries, k).unwrap();
                for (row, &q) in found.chunks(k).zip(&queries) {
                    assert_eq!(row, brute(points, q, k).as_slice(), "query {q}, k {k}");
                }
            }
        }
    }

    #[test]
    fn every_point_at_one_spot_and_all_points_asked_for() {
        let points = vec![[1.5, -2.0]; 9];
        let found = k_nearest(&points, &[4], 9).unwrap();
        assert_eq!(found, (0..9).collect::<Vec<u32>>());
    }

    #[test]
    fn bad_input_is_named() {
        let points = vec![[0.0, 0.0], [1.0, f64::NAN], [2.0, 0.0]];
        assert!(matches!(
            k_nearest(&points, &[0], 2),
            Err(Error::NonFinite {
                index: 1,
                axis: 1,
                ..
            })
        ));
        let points = vec![[0.0, 0.0], [1.0, 0.0]];
        assert!(matches!(
            k_nearest(&points, &[0], 3),
            Err(Error::InvalidParameter { name: "k", .. })
        ));
        assert!(matches!(
            k_nearest(&points, &[2], 1),
            Err(Error::InvalidParameter {
                name: "queries",
                ..
            })
        ));
    }
}
